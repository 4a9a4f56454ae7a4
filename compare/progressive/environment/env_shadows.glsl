// A batch of environment shadow samples (env_shadows.py), full screen over the G-buffer: the terms of
// the shadow ratios of the direct environment light, one per lobe, summed over the batch's u_count
// directions and added to their running sums (additive blending):
//
//   out_terms   = sum_k (V g_d, g_d, V g_s, g_s),  g = luminance(f_lobe(v, w_k) cos) at direction w_k
//   out_weights = sum_k (E_d, E_s, g_s^2)           E: the split sum's unshadowed diffuse and specular
//                                                   luminance (one per sample, as if run one by one)
//
// with V the visibility of w_k through its orthographic shadow map, a tile of one atlas (BATCH tiles,
// punctual_shadow.glsl's u_pface_rect); the split sum does not depend on w, so a batch evaluates it once
// and f the shared BRDF's lobes (Lambert only with MATERIALS_DIFFUSE). The directions are drawn in
// proportion to the map's luminance (per solid angle), so luminance / pdf is one constant for every
// sample and cancels from each ratio sum V g / sum g, which converges to the shadowed over the
// unshadowed light of that lobe. The display weights the two ratios by the lobes' unshadowed light
// (compose.glsl): a glossy lobe's few samples then cannot darken the diffuse light; and a specular
// ratio resting on few effective samples leans on the diffuse one (specular occlusion from the
// diffuse visibility) until enough samples have fallen inside the lobe.

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

#include "brdf.glsl"
#include "mapping.glsl"
#include "ibl.glsl"
#include "layers.glsl"
#include "gbuffer_layers.glsl"
#ifndef BATCH
#error BATCH comes from env_shadows.py (the directions of one pass) as a define
#endif
#include "punctual_shadow.glsl"
#include "gbuffer_inputs.glsl"

uniform sampler2D u_pshadow_map;
uniform vec3 u_camera_position;
uniform vec3 u_directions[BATCH];  // towards the environment (unit), one per tile
uniform int u_count;                // directions of this batch (1 ... BATCH)

layout(location = 0) out vec4 out_terms;
layout(location = 1) out vec4 out_weights;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    load_layers(p);
    vec4 gp = texelFetch(u_position, p, 0);
    out_terms = vec4(0.0);
    out_weights = vec4(0.0);
    if (!(gp.w > 0.5 && gp.w < 1.5)) {
        return;
    }
    vec4 gn = texelFetch(u_normal, p, 0);
    vec4 gm = texelFetch(u_material, p, 0);
    vec3 n = normalize(gn.xyz);
    vec3 v = normalize(u_camera_position - gp.xyz);
    if (dot(n, v) <= 0.0) {
        return;
    }
    const vec3 LUM = vec3(0.2126, 0.7152, 0.0722);
    vec3 env_d;
    vec3 env_s;
    env_split_sum_material(n, v, gm.rgb, gm.a, gn.w, env_d, env_s);
    out_weights = vec4(float(u_count) * vec2(dot(env_d, LUM), dot(env_s, LUM)), 0.0, 0.0);
    vec3 diff_lambert = gm.rgb * (1.0 / BRDF_PI);
    for (int i = 0; i < u_count; ++i) {
        vec3 w = u_directions[i];
        float cos_s = dot(n, w);
        if (cos_s <= 0.0) {
            continue;
        }
        vec3 spec = vec3(0.0);
        vec3 diff = diff_lambert;
#if !MATERIALS_DIFFUSE
        material_lobes(n, v, w, gm.rgb, gm.a, gn.w, spec, diff);
#endif
        // + 1e-6: a black lobe's ratio stays the geometric visibility
        float g_d = (dot(diff, LUM) + 1e-6) * cos_s;
        float g_s = (dot(spec, LUM) + 1e-6) * cos_s;
        float vis = punctual_visibility(u_pshadow_map, i, gp.xyz, n, w);
        out_terms += vec4(vis * g_d, g_d, vis * g_s, g_s);
        out_weights.z += g_s * g_s;  // Kish's effective sample count of the specular ratio: (sum g)^2 / sum g^2
    }
}

#endif
