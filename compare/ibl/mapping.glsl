// Direction mappings of the environment: the GLSL form of
//   compare/scene/environments.py   direction_to_uv (equirectangular, Mitsuba's envmap convention)
//   compare/ibl/cubemap.py    face_coordinates (cube faces, OpenGL's table)
//   compare/image/encodings.py      octahedral_encode
// Functions only, GLSL 3.30; tests/test_ibl.py renders them and compares with numpy.

#ifndef COMPARE_IBL_MAPPING_GLSL
#define COMPARE_IBL_MAPPING_GLSL

#define ENV_PI 3.14159265358979323846

// Equirectangular (u, v) of a unit direction in the map's frame:
// u = atan2(x, -z) / (2 pi) wrapped to [0, 1), v = acos(y) / pi (v = 0 straight up).
vec2 env_direction_to_uv(vec3 d) {
    float u = atan(d.x, -d.z) * (0.5 / ENV_PI);
    u -= floor(u);
    float v = acos(clamp(d.y, -1.0, 1.0)) * (1.0 / ENV_PI);
    return vec2(u, v);
}

// Texture coordinates of (u, v) in a W x H equirectangular texture (GL_REPEAT along s,
// CLAMP_TO_EDGE along t, linear filtering, row 0 uploaded first), interpolating exactly as
// Mitsuba's envmap: column i at u = (i + 1/2) / W (the GL texel centre), row j at
// v = j / (H - 1) (the first and last rows on the poles).
vec2 env_equirect_texcoord(vec2 uv, vec2 size) {
    return vec2(uv.x, (uv.y * (size.y - 1.0) + 0.5) / size.y);
}

// Cube face (0..5 = +X, -X, +Y, -Y, +Z, -Z) and face coordinates st in [-1, 1]^2 of a direction.
// Ties go to x before y before z, as numpy's argmax in cubemap.face_coordinates.
int env_cube_face(vec3 d, out vec2 st) {
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) {
        if (d.x >= 0.0) { st = vec2(-d.z, -d.y) / a.x; return 0; }
        st = vec2(d.z, -d.y) / a.x;
        return 1;
    }
    if (a.y >= a.z) {
        if (d.y >= 0.0) { st = vec2(d.x, d.z) / a.y; return 2; }
        st = vec2(d.x, -d.z) / a.y;
        return 3;
    }
    if (d.z >= 0.0) { st = vec2(d.x, -d.y) / a.z; return 4; }
    st = vec2(-d.x, -d.y) / a.z;
    return 5;
}

// Octahedral coordinates in [0, 1]^2 (+Y at the centre, -Y at the corners).
vec2 env_octahedral_encode(vec3 d) {
    vec3 p = d / (abs(d.x) + abs(d.y) + abs(d.z));
    vec2 f = p.xz;
    if (p.y < 0.0) {
        vec2 s = vec2(p.x >= 0.0 ? 1.0 : -1.0, p.z >= 0.0 ? 1.0 : -1.0);
        f = (1.0 - abs(f.yx)) * s;
    }
    return f * 0.5 + 0.5;
}

#endif // COMPARE_IBL_MAPPING_GLSL
