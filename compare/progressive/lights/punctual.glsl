// The punctual lights' running mean, full screen over the G-buffer, up to BATCH lights per draw
// (punctual.py). Each frame's value is the sum over the lights of their exact light
// (punctual_light.glsl), times the shadow map's visibility for the lights that have their map
// (u_shadowed; punctual_shadow.glsl). The frame's first draw folds the mean,
// A_n = A_(n-1) (1 - 1/n) + c / n (u_fold = 1, no blending); later draws add their c / n
// (additive blending into the same target). Lights are batched because each draw reads the
// G-buffer again: one draw per light made a scene of many lights pay that per light per frame.
//
// Defines: BATCH (1 ... MAX_BATCH in punctual.py), MATERIALS_DIFFUSE (Lambert only).

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

#include "brdf.glsl"
#include "layers.glsl"
#include "gbuffer_layers.glsl"
#include "punctual_light.glsl"
#include "punctual_shadow.glsl"
#include "gbuffer_inputs.glsl"

uniform sampler2D u_previous;  // the mean before this frame
uniform sampler2D u_pshadow[BATCH];
uniform vec3 u_camera_position;
uniform float u_kind[BATCH];   // 0 point, 1 spot, 2 directional
uniform vec3 u_light_position[BATCH];
uniform vec3 u_light_direction[BATCH];
uniform vec3 u_light_intensity[BATCH];
uniform vec2 u_light_cone[BATCH];
uniform float u_shadowed[BATCH];  // 1 once the light has its shadow map
uniform float u_inv_count;     // 1 / n, n the frames of the mean after this one
uniform float u_fold;          // 1: the frame's first draw, which folds the previous mean

out vec4 out_color;

vec3 x_;
vec3 n_;
vec3 v_;
vec4 material_;
float roughness_;

// Light i (sampler arrays take constant indices only: the calls below name each one).
vec3 light(int i, sampler2D shadow) {
    vec3 c = punctual_radiance(x_, n_, v_, material_.rgb, material_.a, roughness_, u_kind[i], u_light_position[i],
                               u_light_direction[i], u_light_intensity[i], u_light_cone[i]);
    if (u_shadowed[i] > 0.5 && max(c.r, max(c.g, c.b)) > 0.0) {
        vec3 l;
        float e;
        punctual_incidence(x_, u_kind[i], u_light_position[i], u_light_direction[i], u_light_cone[i], l, e);
        c *= punctual_visibility(shadow, i, x_, n_, l);
    }
    return c;
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    load_layers(p);
    vec4 gp = texelFetch(u_position, p, 0);
    vec3 c = vec3(0.0);
    if (gp.w > 0.5 && gp.w < 1.5) {
        vec4 gn = texelFetch(u_normal, p, 0);
        x_ = gp.xyz;
        n_ = normalize(gn.xyz);
        v_ = normalize(u_camera_position - gp.xyz);
        material_ = texelFetch(u_material, p, 0);
        roughness_ = gn.w;
        c += light(0, u_pshadow[0]);
#if BATCH > 1
        c += light(1, u_pshadow[1]);
#endif
#if BATCH > 2
        c += light(2, u_pshadow[2]);
#endif
#if BATCH > 3
        c += light(3, u_pshadow[3]);
#endif
#if BATCH > 4
        c += light(4, u_pshadow[4]);
#endif
#if BATCH > 5
        c += light(5, u_pshadow[5]);
#endif
#if BATCH > 6
        c += light(6, u_pshadow[6]);
#endif
#if BATCH > 7
        c += light(7, u_pshadow[7]);
#endif
    }
    c *= u_inv_count;
    if (u_fold > 0.5) {
        vec3 a = u_inv_count < 1.0 ? texelFetch(u_previous, p, 0).rgb : vec3(0.0);
        c += a * (1.0 - u_inv_count);
    }
    out_color = vec4(c, 1.0);
}

#endif
