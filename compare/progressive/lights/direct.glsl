// Direct light of one area-light sample (Otto et al. 2020), full screen over the G-buffer.
//
// For a sample point y on light i (area A, radiance L, normal n_l) and a surface
// point x with normal n, view direction v, this pass computes the single-sample
// estimate
//
//   est = V(x, y) * ( f_d(n, v, l_y) L A cos_s cos_l / |y - x|^2        diffuse through y
//                   + f_s(n, v, l_p) L Omega cos_p (alpha / alpha')^2 )  specular through p
//
// and writes weight * est (weight = F / n_i, see distributor.py). Averaged over the
// n_i samples the diffuse term is the point-on-area Monte Carlo estimate of the
// area integral, exact in the limit (radiometric model). The specular term uses
// Karis' most representative point p (the point of the rectangle closest to the
// reflection ray) with the sphere-light energy normalisation; it is the same for
// every sample, so its mean is the MRP specular times the mean visibility.
//
// Defines: SHADOWS (0 for the unshadowed preview), SHADOW_VSM (variance shadow maps:
// Chebyshev visibility from filtered moments, see shadow.py), AREA_MODEL_PAPER (the paper's
// isotropic point light Phi / (4 pi d^2) instead of L A cos_l / d^2), AREA_MODEL_LTC
// (the shadow ratio's sums instead of the estimate, below), MATERIALS_DIFFUSE (Lambert
// f = c / pi only, for closed-form validation).
//
// With AREA_MODEL_LTC the light itself comes unshadowed and exact from linearly
// transformed cosines (ltc.glsl, ltc_light.glsl) and this pass only estimates how much
// of it is shadowed (Heitz, Hill & McGuire 2018): mode 0 adds, per sample y,
//   (V g_d, g_d, V min(g_s, LTC_SHAPE_MAX s h_s), h_s),  g = mean(f_lobe) A cos_s cos_l / |y - x|^2
// (each lobe's point-sample estimate through y, averaged over RGB; h_s the fitted LTC's own
// density times A cos_l / |y - x|^2, s its scale, see ratio_terms) to the light's ratio
// target: S/U = sum V g_d / sum g_d is the visibility weighted by the diffuse integrand, and
// the specular one, sum V min(...) / (s sum h_s), also corrects the fitted lobe (ltc.py,
// ltc_compose.glsl).

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

#include "brdf.glsl"
#include "layers.glsl"
#include "gbuffer_layers.glsl"
#include "gbuffer_inputs.glsl"

uniform sampler2D u_partial;   // this frame's sum of its earlier samples
uniform sampler2D u_previous;  // direct running mean before this frame

uniform vec3 u_camera_position;
uniform vec3 u_light_center;
uniform vec3 u_light_t;        // unit tangent (first side)
uniform vec3 u_light_b;        // unit bitangent (second side), t x b = n
uniform vec3 u_light_n;        // unit normal, the emitting side
uniform vec2 u_light_half;     // half side lengths along t and b
uniform vec3 u_light_radiance;
uniform float u_light_area;
uniform vec3 u_sample;         // the sample point y on the light
uniform float u_weight;        // F / n_i (1 for the preview)
uniform int u_mode;            // 0: output weight * est (blended additively); 1: update the running mean
uniform float u_count;         // mode 1: units of the mean after this frame (light frames, or samples)
uniform float u_units;         // mode 1: units this frame adds (1 per frame, or its number of samples)
uniform float u_use_partial;   // mode 1: add u_partial (the frame's earlier samples)

#if SHADOWS
#if SHADOW_VSM
#include "vsm.glsl"
#endif
#include "shadow_test.glsl"
#endif

out vec4 out_color;

#include "area_light.glsl"
#include "ltc.glsl"

#if AREA_MODEL_LTC
uniform sampler2D u_ltc_specular;  // the light's unshadowed specular sum; a: sum of its scale s
uniform float u_ltc_inv_frames;    // 1 / the frames in that sum
#ifndef LTC_SHAPE_MAX
#error LTC_SHAPE_MAX comes from direct.py (LTC_SHAPE_MAX) as a define
#endif
// The unshadowed integrands of the shadow ratio through y. They carry the material (as
// Heitz et al.'s estimates do): at a pixel whose jittered frames see two surfaces, each
// sample then weighs as much as its surface's light, as in the unshadowed mean it scales.
vec4 ratio_terms(vec3 x, vec3 n, vec3 v, vec3 y, vec3 base, float metallic, float roughness) {
    if (!light_reaches(x, n, v)) {
        return vec4(0.0);
    }
    vec3 l;
    float d2;
    float cos_s;
    float cos_l;
    sample_direction(x, n, y, l, d2, cos_s, cos_l);
    if (cos_s <= 0.0 || cos_l <= 0.0) {
        return vec4(0.0);
    }
    float g_d = point_solid_angle(d2, cos_l) * cos_s;
    float g_s = 0.0;
#if !MATERIALS_DIFFUSE
    vec3 spec_lobe;
    vec3 diff_lobe;
    // The coat's own lobe is left out: ltc.glsl lights it with the diffuse sum, which the diffuse
    // ratio shadows; the specular ratio converges to the base's shadowed specular light.
    float coat;
    material_lobes_split(n, v, l, base, metallic, roughness, spec_lobe, diff_lobe, coat);
    g_s = dot(spec_lobe, vec3(1.0 / 3.0)) * g_d;
    // The specular ratio's denominator is the transformed cosine's own estimate through y (the
    // closed form it scales, per sample), not the BRDF's: the ratio then corrects the fitted
    // lobe's shape and Fresnel as well as the shadows, and converges to the exact shadowed light.
    // The closed form's scale s (Fresnel x (A + B), a constant of the pixel) is left out here and
    // applied by the compose pass: the light's unshadowed specular sum carries it (ltc_light.glsl),
    // so this pass need not evaluate the polygon integral again per sample (docs/performance-notes.md).
    float h_s = ltc_density(n, v, l, roughness) * point_solid_angle(d2, cos_l);
    // Where the fitted lobe has (almost) no density the BRDF may still have some: bounded at
    // LTC_SHAPE_MAX times the lobe's own, s h_s, a sample cannot make a firefly of the ratio.
    float scale = texelFetch(u_ltc_specular, ivec2(gl_FragCoord.xy), 0).a * u_ltc_inv_frames;
    g_s = min(g_s, LTC_SHAPE_MAX * scale * h_s);
    // + 1e-6: a metal's diffuse lobe is zero, and its diffuse ratio (the specular one's
    // fallback) stays the geometric visibility.
    g_d *= dot(diff_lobe, vec3(1.0 / 3.0)) + 1e-6;
#else
    float h_s = 0.0;
#endif
    vec4 terms = vec4(g_d, g_d, g_s, h_s);
#if SHADOWS
    if (g_d > 0.0) {
        float vis = visibility(x, n);
        terms.xz *= vis;
    }
#endif
    return terms;
}
#endif

vec3 sample_estimate(vec3 x, vec3 n, vec3 base, float metallic, float roughness) {
    vec3 est = light_estimate(x, n, normalize(u_camera_position - x), u_sample, base, metallic, roughness);
#if SHADOWS
    if (max(est.r, max(est.g, est.b)) > 0.0) {
        est *= visibility(x, n);
    }
#endif
    return est;
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    load_layers(p);
    vec4 gp = texelFetch(u_position, p, 0);
    bool shaded = gp.w > 0.5 && gp.w < 1.5;
#if AREA_MODEL_LTC
    out_color = vec4(0.0);
    if (shaded) {
        vec4 gn = texelFetch(u_normal, p, 0);
        vec4 gm = texelFetch(u_material, p, 0);
        out_color = ratio_terms(gp.xyz, normalize(gn.xyz), normalize(u_camera_position - gp.xyz), u_sample, gm.rgb,
                                gm.a, gn.w);
    }
#else
    vec3 c = vec3(0.0);
    if (shaded) {
        vec4 gn = texelFetch(u_normal, p, 0);
        vec4 gm = texelFetch(u_material, p, 0);
        c = u_weight * sample_estimate(gp.xyz, normalize(gn.xyz), gm.rgb, gm.a, gn.w);
    }
    if (u_mode == 0) {
        out_color = vec4(c, 1.0);
        return;
    }
    if (u_use_partial > 0.5) {
        c += texelFetch(u_partial, p, 0).rgb;
    }
    vec3 a = u_count > u_units ? texelFetch(u_previous, p, 0).rgb : vec3(0.0);
    out_color = vec4(a + (c - u_units * a) / u_count, 1.0);
#endif
}

#endif
