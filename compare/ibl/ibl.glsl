// Environment lighting for the rasterizer: background, split-sum specular, diffuse irradiance.
//
// Reads what compare.ibl.preprocess made (uploaded by compare/progressive/environment/environment.py):
//   u_env_map         the equirectangular radiance map itself (background), mapping.glsl's convention
//   u_env_atlas       the prefiltered chain as a 2D atlas (compare/ibl/atlas.py): cube faces or
//                     octahedral squares with 1-texel borders, level i for roughness i / (L - 1)
//   u_env_irradiance  the convolved irradiance cube (one padded level, same atlas layout), or
//   u_env_sh9         nine SH coefficients already multiplied by A_l (ENV_DIFFUSE_SH9)
//   u_env_lut         split-sum table: A, B, C over (n.v, roughness) (compare/ibl/lut.py)
//
//   specular = prefiltered(reflect(-v, n), r) * (F0 A + B)            Karis' split sum
//   diffuse  = (1 - m) c E(n) / pi * C(n.v)                           (Lambert only: c E / pi)
//
// Defines: ENV_OCTAHEDRAL (atlas of octahedral maps), ENV_RGBM (atlas in RGBM, sqrt, range 7),
// ENV_DIFFUSE_SH9 (SH9 instead of the irradiance cube), MATERIALS_DIFFUSE (Lambert only).
// Needs brdf.glsl (F0) and mapping.glsl included first.

#ifndef COMPARE_IBL_GLSL
#define COMPARE_IBL_GLSL

// compare.ibl.MAX_LEVELS, written ahead of this file by compare.ibl.glsl_source().
#ifndef ENV_MAX_LEVELS
#error ENV_MAX_LEVELS comes from compare/ibl/__init__.py (MAX_LEVELS) as a define
#endif

uniform sampler2D u_env_map;
uniform vec2 u_env_map_size;
uniform sampler2D u_env_atlas;
uniform vec2 u_env_atlas_size;
uniform vec3 u_env_levels[ENV_MAX_LEVELS];  // per level: tile origin x, origin y, interior size
uniform float u_env_max_lod;                // levels - 1
uniform sampler2D u_env_irradiance;
uniform vec2 u_env_irradiance_size;
uniform float u_env_irradiance_face;        // interior face size of the irradiance cube
uniform vec3 u_env_sh9[9];
uniform sampler2D u_env_lut;
uniform mat3 u_env_to_map;                  // world -> map frame (inverse of the environment's rotation)
uniform float u_env_intensity;

// Radiance of the map towards a world direction (what a camera ray that misses sees).
vec3 env_background(vec3 world_dir) {
    vec2 uv = env_direction_to_uv(normalize(u_env_to_map * world_dir));
    return u_env_intensity * textureLod(u_env_map, env_equirect_texcoord(uv, u_env_map_size), 0.0).rgb;
}

// The map seen through the pixel at frag_coord (gl_FragCoord.xy) of a camera whose
// jittered view-projection has the inverse inv_view_proj, on a viewport of that size.
vec3 env_background_at_pixel(vec2 frag_coord, vec2 viewport, mat4 inv_view_proj) {
    vec2 ndc = frag_coord / viewport * 2.0 - 1.0;
    vec4 far_point = inv_view_proj * vec4(ndc, 1.0, 1.0);
    vec4 near_point = inv_view_proj * vec4(ndc, -1.0, 1.0);
    return env_background(far_point.xyz / far_point.w - near_point.xyz / near_point.w);
}

// One face of a padded cube tile at (origin, size): bilinear through the hardware.
vec2 env_cube_texel(vec3 d, vec2 origin, float size) {
    vec2 st;
    int face = env_cube_face(d, st);
    return origin + vec2(float(face) * (size + 2.0), 0.0) + (st * 0.5 + 0.5) * size + 1.0;
}

vec3 env_atlas_level(vec3 d, int level) {
    vec3 l = u_env_levels[level];
#if ENV_OCTAHEDRAL
    vec2 px = l.xy + env_octahedral_encode(d) * l.z + 1.0;
#else
    vec2 px = env_cube_texel(d, l.xy, l.z);
#endif
    vec4 t = textureLod(u_env_atlas, px / u_env_atlas_size, 0.0);
#if ENV_RGBM
    vec3 c = 7.0 * t.rgb * t.a;  // RGBM, sqrt encoding, range 7 (maximum 49)
    return c * c;
#else
    return t.rgb;
#endif
}

// Prefiltered radiance for perceptual roughness r: level lod = r (L - 1), two levels blended.
vec3 env_prefiltered(vec3 d, float roughness) {
    float lod = clamp(roughness, 0.0, 1.0) * u_env_max_lod;
    int lo = int(floor(lod));
    int hi = min(lo + 1, int(u_env_max_lod));
    float f = lod - float(lo);
    vec3 c = env_atlas_level(d, lo);
    if (f > 0.0) {
        c = mix(c, env_atlas_level(d, hi), f);
    }
    return c;
}

// Irradiance E(n) (W/m^2) towards a map-frame normal.
vec3 env_irradiance(vec3 n) {
#if ENV_DIFFUSE_SH9
    float x = n.x;
    float y = n.y;
    float z = n.z;
    vec3 e = u_env_sh9[0] * 0.282095
           + u_env_sh9[1] * (0.488603 * y) + u_env_sh9[2] * (0.488603 * z) + u_env_sh9[3] * (0.488603 * x)
           + u_env_sh9[4] * (1.092548 * x * y) + u_env_sh9[5] * (1.092548 * y * z)
           + u_env_sh9[6] * (0.315392 * (3.0 * z * z - 1.0)) + u_env_sh9[7] * (1.092548 * x * z)
           + u_env_sh9[8] * (0.546274 * (x * x - y * y));
    return max(e, vec3(0.0));
#else
    vec2 px = env_cube_texel(n, vec2(0.0), u_env_irradiance_face);
    return textureLod(u_env_irradiance, px / u_env_irradiance_size, 0.0).rgb;
#endif
}

// Split-sum table: A, B (specular scale and bias) and C (diffuse directional factor).
vec3 env_lut(float n_dot_v, float roughness) {
    return textureLod(u_env_lut, vec2(n_dot_v, clamp(roughness, 0.0, 1.0)), 0.0).rgb;
}

// Unoccluded environment light reflected towards v, split into its diffuse and specular terms.
// Zero when n.v <= 0 (the shared BRDF is one-sided).
void env_split_sum(vec3 n, vec3 v, vec3 base, float metallic, float roughness,
                   out vec3 diffuse, out vec3 specular) {
    diffuse = vec3(0.0);
    specular = vec3(0.0);
    float nv = dot(n, v);
    if (nv <= 0.0) {
        return;
    }
    vec3 e = env_irradiance(normalize(u_env_to_map * n));
#if MATERIALS_DIFFUSE
    diffuse = u_env_intensity * base * e * (1.0 / ENV_PI);
#else
    float m = clamp(metallic, 0.0, 1.0);
    vec3 abc = env_lut(nv, roughness);
    vec3 f0 = vec3(BRDF_DIELECTRIC_F0) + (base - vec3(BRDF_DIELECTRIC_F0)) * m;
    vec3 r = reflect(-v, n);
    specular = u_env_intensity * env_prefiltered(normalize(u_env_to_map * r), roughness) * (f0 * abc.x + abc.y);
    diffuse = u_env_intensity * (1.0 - m) * base * e * (abc.z / ENV_PI);
#endif
}

#endif // COMPARE_IBL_GLSL
