// Progressive screen-space occlusion of the environment light (Otto et al. 2020, section 3.2).
//
// Each environment sample s of this frame (compare/progressive/schedule/distributor.py) is either
// diffuse (a cosine-weighted direction) or specular (a GGX visible normal reflected about
// the view vector, compare/brdf/brdf.glsl), in the tangent frame of the pixel's normal.
// The point p = x + dir * d_occ * xi_3 is projected with this frame's camera; if the
// surface stored at that pixel is in front of p by more than the bias and by less than
// d_occ (a hit within the occlusion distance), the sample is occluded. Its estimate of the
// visible light is
//
//   term_kind * V_s,    term = the unoccluded split-sum diffuse or specular light (ibl.glsl)
//
// and every kind has its own running mean over its samples (two targets): with m samples
// of a kind in this frame and n before, A <- A + (sum of the m estimates - m A) / (n + m).
// Once both kinds have samples, compose.glsl shows their sum in place of the unoccluded
// light, so the image is diffuse * mean(V_d) + specular * mean(V_s) after any number of
// frames — an unbiased estimate that is never negative.
//
// A sample that reflects below the surface (possible for GGX at grazing views), leaves the
// screen or lands on the background counts as visible: screen space knows nothing there.
// The azimuth of every sample is rotated per pixel by a fixed hash of the pixel, so that
// neighbouring pixels test different directions while each pixel still walks through the
// low-discrepancy sequence.

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

#include "brdf.glsl"
#include "mapping.glsl"
#include "ibl.glsl"
#include "layers.glsl"
#include "gbuffer_layers.glsl"
#include "gbuffer_inputs.glsl"

#ifndef MAX_ENV_SAMPLES
#error MAX_ENV_SAMPLES comes from environment.py (MAX_SAMPLES_PER_FRAME) as a define
#endif

uniform sampler2D u_prev_diffuse;   // running means before this frame
uniform sampler2D u_prev_specular;

uniform mat4 u_view_proj;      // this frame's jittered camera
uniform vec3 u_camera_position;
uniform vec3 u_camera_forward;
uniform vec2 u_viewport;
uniform float u_d_occ;         // occlusion distance (world units)
uniform float u_occ_bias;      // depth bias (world units)
uniform vec2 u_counts;         // samples of each kind (diffuse, specular) before this frame
uniform int u_sample_count;
uniform int u_sample_kind[MAX_ENV_SAMPLES];       // 0 diffuse, 1 specular
uniform vec3 u_sample_u[MAX_ENV_SAMPLES];         // xi_1 (azimuth), xi_2, xi_3 (distance fraction)

layout(location = 0) out vec4 out_diffuse;
layout(location = 1) out vec4 out_specular;

// Duff et al. 2017 orthonormal basis around n (the same as compare/ibl/prefilter.py).
void onb(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

float pixel_hash(ivec2 p) {
    // Interleaved gradient noise (Jimenez 2014): a fixed value in [0, 1) per pixel.
    return fract(52.9829189 * fract(0.06711056 * float(p.x) + 0.00583715 * float(p.y)));
}

// 1 when the point p is hidden behind the depth buffer (within d_occ), else 0.
float occluded(vec3 p) {
    vec4 clip = u_view_proj * vec4(p, 1.0);
    if (clip.w <= 0.0) {
        return 0.0;
    }
    vec2 ndc = clip.xy / clip.w;
    if (any(greaterThan(abs(ndc), vec2(1.0)))) {
        return 0.0;
    }
    ivec2 px = clamp(ivec2((ndc * 0.5 + 0.5) * u_viewport), ivec2(0), ivec2(u_viewport) - 1);
    vec4 stored = texelFetch(u_position, px, 0);
    if (stored.w < 0.5) {
        return 0.0;  // background
    }
    float z_p = dot(p - u_camera_position, u_camera_forward);
    float z_s = dot(stored.xyz - u_camera_position, u_camera_forward);
    float gap = z_p - z_s;
    return (gap > u_occ_bias && gap < u_d_occ) ? 1.0 : 0.0;
}

// Running mean over samples: m new estimates with sum c after n earlier ones.
vec3 running_mean(vec3 a, vec3 c, float m, float n) {
    if (n <= 0.0) {
        return m > 0.0 ? c / m : vec3(0.0);  // the first samples overwrite (the target starts undefined)
    }
    return m > 0.0 ? a + (c - m * a) / (n + m) : a;
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    load_layers(p);
    vec4 gp = texelFetch(u_position, p, 0);
    vec3 c_d = vec3(0.0);
    vec3 c_s = vec3(0.0);
    float m_d = 0.0;
    float m_s = 0.0;
    for (int i = 0; i < u_sample_count; ++i) {
        if (u_sample_kind[i] == 0) {
            m_d += 1.0;
        } else {
            m_s += 1.0;
        }
    }
    if (gp.w > 0.5 && gp.w < 1.5) {
        vec4 gn = texelFetch(u_normal, p, 0);
        vec4 gm = texelFetch(u_material, p, 0);
        vec3 x = gp.xyz;
        vec3 n = normalize(gn.xyz);
        vec3 v = normalize(u_camera_position - x);
        vec3 diffuse;
        vec3 specular;
        env_split_sum_material(n, v, gm.rgb, gm.a, gn.w, diffuse, specular);
        vec3 t;
        vec3 b;
        onb(n, t, b);
        vec3 v_local = vec3(dot(v, t), dot(v, b), dot(v, n));
        float rotation = pixel_hash(p);
        float alpha = brdf_alpha_from_roughness(gn.w);
        for (int i = 0; i < u_sample_count; ++i) {
            vec3 xi = u_sample_u[i];
            vec2 u = vec2(fract(xi.x + rotation), xi.y);
            bool is_diffuse = u_sample_kind[i] == 0;
            vec3 term = is_diffuse ? diffuse : specular;
            float visible = 1.0;
            vec3 l;
            if (is_diffuse) {
                float r = sqrt(u.y);
                float phi = 2.0 * ENV_PI * u.x;
                l = vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u.y, 0.0)));
            } else {
                vec3 h = brdf_sample_ggx_vndf(v_local, alpha, u);
                l = reflect(-v_local, h);
            }
            if (l.z > 0.0 && max(term.r, max(term.g, term.b)) > 0.0) {
                vec3 dir = t * l.x + b * l.y + n * l.z;
                visible = 1.0 - occluded(x + dir * (u_d_occ * xi.z));
            }
            if (is_diffuse) {
                c_d += term * visible;
            } else {
                c_s += term * visible;
            }
        }
    }
#if OCCLUSION
    float ao = texelFetch(u_emission, p, 0).a;  // the occlusion map's factor (gbuffer.glsl)
    c_d *= ao;
    c_s *= ao;
#endif
    out_diffuse = vec4(running_mean(texelFetch(u_prev_diffuse, p, 0).rgb, c_d, m_d, u_counts.x), 1.0);
    out_specular = vec4(running_mean(texelFetch(u_prev_specular, p, 0).rgb, c_s, m_s, u_counts.y), 1.0);
}

#endif
