// The visibility of a light sample y from a surface point x through ShadowAtlas's five-face
// atlas (shadow.py): shared by the direct-light pass (direct.glsl) and the irradiance
// volume's bake (probes_direct.glsl), so that both test shadows alike.
//
// The includer declares u_sample (the sample point y) and the light's frame u_light_t,
// u_light_b, u_light_n before including this, and, with SHADOW_VSM, includes vsm.glsl first.

#ifndef COMPARE_SHADOW_TEST_GLSL
#define COMPARE_SHADOW_TEST_GLSL

uniform sampler2D u_shadow;            // depth atlas: distance from y to the nearest surface / far
uniform float u_shadow_far;            // the far distance of the shadow faces
uniform mat4 u_face_view_proj[5];      // front (+n), +t, -t, +b, -b
uniform vec4 u_face_rect[5];           // tile origin (xy) and size (zw) in texels
uniform float u_shadow_texel;          // size of one texel in tangent units (2 / S)
uniform vec3 u_bias;                   // normal offset, constant and slope-scaled bias, in texels
#if SHADOW_VSM
// With SHADOW_VSM, u_shadow holds the filtered moments (d, d^2) in world units instead of the depth.
uniform vec2 u_vsm;                    // minimum standard deviation (fraction of d), light-bleeding reduction
#endif

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

#endif // COMPARE_SHADOW_TEST_GLSL
