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
// isotropic point light Phi / (4 pi d^2) instead of L A cos_l / d^2),
// MATERIALS_DIFFUSE (Lambert f = c / pi only, for closed-form validation).

#if defined VERTEX_SHADER

void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}

#elif defined FRAGMENT_SHADER

#include "brdf.glsl"

uniform sampler2D u_position;  // G-buffer: world position, w = kind
uniform sampler2D u_normal;    // G-buffer: shading normal, w = roughness
uniform sampler2D u_material;  // G-buffer: base colour, a = metallic
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
uniform sampler2D u_shadow;            // depth atlas: distance from y to the nearest surface / far
uniform float u_shadow_far;            // the far distance of the shadow faces
uniform mat4 u_face_view_proj[5];      // front (+n), +t, -t, +b, -b
uniform vec4 u_face_rect[5];           // tile origin (xy) and size (zw) in texels
uniform float u_shadow_texel;          // size of one texel in tangent units (2 / S)
uniform vec3 u_bias;                   // normal offset, constant and slope-scaled bias, in texels
#if SHADOW_VSM
// With SHADOW_VSM, u_shadow holds the filtered moments (d, d^2) in world units instead of the depth.
uniform vec2 u_vsm;                    // minimum standard deviation (fraction of d), light-bleeding reduction
#include "vsm.glsl"
#endif
#endif

out vec4 out_color;

#include "area_light.glsl"

#if SHADOWS
// Visibility of y from x through the five-face shadow atlas.
//
// Bias, all in units of the shadow texel's world size at x's distance (texel = 2 d / S):
// the receiver is moved along its normal (turned towards y) by u_bias.x texels
// (normal offset), then compared with the stored distance plus
// u_bias.y + u_bias.z * tan(theta) texels (constant + slope-scaled; theta is the angle
// between the normal and the direction to y, tan capped at 10).
// SHADOW_VSM: the same face, offset and bias, then Chebyshev's bound of the filtered
// moments (bilinear, clamped half a texel inside the face's tile) instead of the hard test.
float visibility(vec3 x, vec3 n) {
    vec3 to_y = u_sample - x;
    float dist = length(to_y);
    float texel = u_shadow_texel * dist;
    float c = dot(n, to_y) / max(dist, 1e-20);
    vec3 n_y = c >= 0.0 ? n : -n;
    c = clamp(abs(c), 1e-3, 1.0);
    float tan_theta = min(sqrt(1.0 - c * c) / c, 10.0);
    vec3 xo = x + n_y * (u_bias.x * texel);
    vec3 d = xo - u_sample;
    vec3 q = vec3(dot(d, u_light_t), dot(d, u_light_b), dot(d, u_light_n));
    int face;
    if (q.z >= abs(q.x) && q.z >= abs(q.y)) {
        face = 0;
    } else if (abs(q.x) >= abs(q.y)) {
        face = q.x > 0.0 ? 1 : 2;
    } else {
        face = q.y > 0.0 ? 3 : 4;
    }
    vec4 clip = u_face_view_proj[face] * vec4(xo, 1.0);
    vec2 ndc = clip.xy / max(clip.w, 1e-20);
    vec4 rect = u_face_rect[face];
#if SHADOW_VSM
    vec2 pos = clamp(rect.xy + (ndc * 0.5 + 0.5) * rect.zw, rect.xy + 0.5, rect.xy + rect.zw - 0.5);
    vec2 moments = textureLod(u_shadow, pos / vec2(textureSize(u_shadow, 0)), 0.0).rg;
    float r = length(d) - texel * (u_bias.y + u_bias.z * tan_theta);
    float sigma = u_vsm.x * r;
    return vsm_visibility(moments, r, sigma * sigma, u_vsm.y);
#else
    vec2 texel_pos = clamp(rect.xy + (ndc * 0.5 + 0.5) * rect.zw, rect.xy, rect.xy + rect.zw - 1.0);
    float stored = texelFetch(u_shadow, ivec2(texel_pos), 0).r * u_shadow_far;
    float bias = texel * (u_bias.y + u_bias.z * tan_theta);
    return length(d) <= stored + bias ? 1.0 : 0.0;
#endif
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
    vec4 gp = texelFetch(u_position, p, 0);
    vec3 c = vec3(0.0);
    if (gp.w > 0.5 && gp.w < 1.5) {
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
}

#endif
