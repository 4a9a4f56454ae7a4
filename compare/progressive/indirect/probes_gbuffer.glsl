// Irradiance-volume bake, step 1: the scene from every probe into six cube faces, one instance
// per (probe, face), all in one atlas of S x S tiles (compare/progressive/indirect/probes.py).
//
// Instance i draws probe i / 6, face i % 6, where i is the draw's instance number or, with
// u_instance_offset >= 0, entry u_instance_offset + gl_InstanceID of the list u_instances: the
// (probe, face) pairs whose view the mesh's bounds reach (the others would draw nothing). The face's camera looks along A with U to the
// right and V up (compare/ibl/cubemap.py's table, so texel (column, row) of a tile, counted
// from the tile's lower left, looks along A + s U + t V at its centre). Clip distances keep
// each face inside its own tile; the clip-space x, y are then moved and scaled into the tile.
//
// Targets: position + distance to the probe, normal + kind (0 miss, 1 surface, 2 light quad),
// diffuse albedo + side (1 front, -1 back), emission towards the probe (front side only).

#if defined VERTEX_SHADER

in vec3 in_position;
in vec3 in_normal;
#include "material_vertex.glsl"

uniform ivec3 u_counts;    // probes along x, y, z
uniform vec3 u_origin;     // position of probe (0, 0, 0)
uniform vec3 u_spacing;
uniform int u_tiles;       // probes per atlas row (each 6 faces wide)
uniform float u_face;      // face size S in texels
uniform vec2 u_atlas;      // atlas size in texels
uniform vec3 u_face_a[6];
uniform vec3 u_face_u[6];
uniform vec3 u_face_v[6];
uniform vec2 u_depth;      // ((f + n) / (f - n), 2 f n / (f - n)) of the faces' perspective
uniform isampler2D u_instances;  // the (probe, face) lists of every mesh, row by row
uniform int u_instance_offset;   // where this mesh's list starts; negative: every instance

out vec3 v_position;
out vec3 v_normal;
flat out vec3 v_probe;

void main() {
    int instance = gl_InstanceID;
    if (u_instance_offset >= 0) {
        int k = u_instance_offset + gl_InstanceID;
        int width = textureSize(u_instances, 0).x;
        instance = texelFetch(u_instances, ivec2(k % width, k / width), 0).r;
    }
    int probe = instance / 6;
    int face = instance - 6 * probe;
    ivec3 idx = ivec3(probe % u_counts.x, (probe / u_counts.x) % u_counts.y, probe / (u_counts.x * u_counts.y));
    vec3 c = u_origin + vec3(idx) * u_spacing;
    vec3 d = in_position - c;
    float w = dot(d, u_face_a[face]);
    vec4 clip = vec4(dot(d, u_face_u[face]), dot(d, u_face_v[face]), w * u_depth.x - u_depth.y, w);
    gl_ClipDistance[0] = clip.w + clip.x;
    gl_ClipDistance[1] = clip.w - clip.x;
    gl_ClipDistance[2] = clip.w + clip.y;
    gl_ClipDistance[3] = clip.w - clip.y;
    vec2 origin = vec2(float((probe % u_tiles) * 6 + face), float(probe / u_tiles)) * u_face;
    vec2 offset = (origin + 0.5 * u_face) / u_atlas * 2.0 - 1.0;
    gl_Position = vec4(clip.xy * (u_face / u_atlas) + offset * clip.w, clip.z, clip.w);
    v_position = in_position;
    v_normal = in_normal;
    material_vertex();
    v_probe = c;
}

#elif defined FRAGMENT_SHADER

in vec3 v_position;
in vec3 v_normal;
flat in vec3 v_probe;

#include "material.glsl"

uniform float u_kind;      // 1 = shaded surface, 2 = light quad (reflects nothing)
uniform int u_lambert;     // 1: materials "diffuse" (albedo = base colour, metallic ignored)

layout(location = 0) out vec4 out_position;  // world position, w = distance to the probe
layout(location = 1) out vec4 out_normal;    // unit normal, w = kind
layout(location = 2) out vec4 out_albedo;    // diffuse albedo (1 - m) c, w = 1 front / -1 back
layout(location = 3) out vec4 out_emission;  // emitted radiance towards the probe

void main() {
    alpha_test();
    vec3 n = normalize(v_normal);
    vec3 to_probe = v_probe - v_position;
    bool front = dot(n, to_probe) > 0.0;
    float m = u_lambert == 1 ? 0.0 : clamp(material_metallic(), 0.0, 1.0);
    out_position = vec4(v_position, length(to_probe));
    out_normal = vec4(front ? material_normal(n) : n, u_kind);
    out_albedo = vec4((1.0 - m) * material_base_color(), front ? 1.0 : -1.0);
    out_emission = vec4(front ? material_emission() : vec3(0.0), 1.0);
}

#endif
