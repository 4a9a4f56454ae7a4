// The visibility of a punctual light from a surface point through its shadow map
// (punctual.py): one face (a spot's perspective map, a directional light's orthographic map)
// or six (a point light's cube, +x -x +y -y +z -z, in one atlas of 3 x 2 tiles).
//
// Depth is the Euclidean distance from the light (orthographic: the distance along the light's
// direction from the map's near plane) divided by the map's far distance, as shadow.glsl writes
// it with or without ORTHO. Bias as the area lights' test (shadow_test.glsl), in texels of the
// map's world size at the receiver: texel = u_pshadow_texel[i].x * distance + u_pshadow_texel[i].y.
//
// The includer defines BATCH, the number of lights of one pass; light i's faces are
// u_pface_*[6 i ...].

#ifndef COMPARE_PUNCTUAL_SHADOW_GLSL
#define COMPARE_PUNCTUAL_SHADOW_GLSL

uniform int u_pshadow_faces[BATCH];        // 1 or 6
uniform mat4 u_pface_view_proj[6 * BATCH];
uniform vec4 u_pface_rect[6 * BATCH];      // tile origin (xy) and size (zw) in texels
uniform vec3 u_pshadow_origin[BATCH];      // the light's position; orthographic: the eye of its map
uniform vec3 u_pshadow_direction[BATCH];   // orthographic: the light's direction of travel
uniform float u_pshadow_ortho[BATCH];      // 1 for a directional light's orthographic map
uniform float u_pshadow_far[BATCH];
uniform vec2 u_pshadow_texel[BATCH];
uniform vec3 u_bias;                       // normal offset, constant and slope-scaled bias, in texels

float punctual_metric(int i, vec3 p) {
    return u_pshadow_ortho[i] > 0.5 ? dot(p - u_pshadow_origin[i], u_pshadow_direction[i])
                                    : distance(p, u_pshadow_origin[i]);
}

// Visibility of light i (its map: shadow) from x (normal n; l the unit direction to the light).
float punctual_visibility(sampler2D shadow, int i, vec3 x, vec3 n, vec3 l) {
    float texel = u_pshadow_texel[i].x * punctual_metric(i, x) + u_pshadow_texel[i].y;
    float c = dot(n, l);
    vec3 n_l = c >= 0.0 ? n : -n;
    c = clamp(abs(c), 1e-3, 1.0);
    float tan_theta = min(sqrt(1.0 - c * c) / c, 10.0);
    vec3 xo = x + n_l * (u_bias.x * texel);
    int face = 0;
    if (u_pshadow_faces[i] == 6) {
        vec3 d = xo - u_pshadow_origin[i];
        vec3 a = abs(d);
        if (a.x >= a.y && a.x >= a.z) {
            face = d.x > 0.0 ? 0 : 1;
        } else if (a.y >= a.z) {
            face = d.y > 0.0 ? 2 : 3;
        } else {
            face = d.z > 0.0 ? 4 : 5;
        }
    }
    vec4 clip = u_pface_view_proj[6 * i + face] * vec4(xo, 1.0);
    vec2 ndc = clip.xy / max(clip.w, 1e-20);
    if (clip.w <= 0.0 || abs(ndc.x) > 1.0 || abs(ndc.y) > 1.0) {
        return 1.0;  // outside the map: beyond a spot's cone (no light) or the fitted area (nothing to cast)
    }
    vec4 rect = u_pface_rect[6 * i + face];
    vec2 texel_pos = clamp(rect.xy + (ndc * 0.5 + 0.5) * rect.zw, rect.xy, rect.xy + rect.zw - 1.0);
    float stored = texelFetch(shadow, ivec2(texel_pos), 0).r * u_pshadow_far[i];
    return punctual_metric(i, xo) <= stored + texel * (u_bias.y + u_bias.z * tan_theta) ? 1.0 : 0.0;
}

#endif // COMPARE_PUNCTUAL_SHADOW_GLSL
