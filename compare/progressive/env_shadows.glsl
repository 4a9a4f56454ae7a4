// One environment shadow sample (env_shadows.py), full screen over the G-buffer: the terms of the
// shadow ratio of the direct environment light, added to its running sums (additive blending):
//
//   (V g, g),   g = luminance(f(v, w) cos) at the sample's direction w
//
// with V the visibility of w through the sample's orthographic shadow map (punctual_shadow.glsl)
// and f the shared BRDF (Lambert only with MATERIALS_DIFFUSE). The directions are drawn in proportion
// to the map's luminance (times sin theta, the equirect's area), so luminance / pdf is one constant for
// every sample and cancels from the ratio sum V g / sum g, which converges to the shadowed over the
// unshadowed direct environment light of the pixel (in luminance).

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

#include "brdf.glsl"
#define BATCH 1
#include "punctual_shadow.glsl"

uniform sampler2D u_position;  // G-buffer: world position, w = kind
uniform sampler2D u_normal;    // G-buffer: shading normal, w = roughness
uniform sampler2D u_material;  // G-buffer: base colour, a = metallic
uniform sampler2D u_pshadow_map;
uniform vec3 u_camera_position;
uniform vec3 u_direction;      // towards the environment (unit)

out vec4 out_terms;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 gp = texelFetch(u_position, p, 0);
    out_terms = vec4(0.0);
    if (!(gp.w > 0.5 && gp.w < 1.5)) {
        return;
    }
    vec4 gn = texelFetch(u_normal, p, 0);
    vec4 gm = texelFetch(u_material, p, 0);
    vec3 n = normalize(gn.xyz);
    vec3 v = normalize(u_camera_position - gp.xyz);
    float cos_s = dot(n, u_direction);
    if (cos_s <= 0.0 || dot(n, v) <= 0.0) {
        return;
    }
#if MATERIALS_DIFFUSE
    vec3 f = gm.rgb * (1.0 / BRDF_PI);
#else
    vec3 f = brdf_eval(n, v, u_direction, gm.rgb, gm.a, gn.w);
#endif
    // + 1e-6: a black pixel's ratio stays the geometric visibility
    float g = (dot(f, vec3(0.2126, 0.7152, 0.0722)) + 1e-6) * cos_s;
    float vis = punctual_visibility(u_pshadow_map, 0, gp.xyz, n, u_direction);
    out_terms = vec4(vis * g, g, 0.0, 0.0);
}

#endif
