// The shadowed direct light of one light with the ltc area model (Heitz, Hill & McGuire
// 2018): its unshadowed light in closed form, averaged over the frames' jitter, times
// the shadow ratio S / U of its samples so far, for the diffuse and the specular lobe
// each (direct.glsl writes the sums). Drawn once per light, added up.
//
// Where a lobe's sum U is zero (no sample reached it yet, or none was above the
// surface's horizon) its ratio falls back on the other lobe's, and on 1 (unshadowed)
// where both are: before its first sample a light is shown unshadowed, and exact.

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

uniform sampler2D u_diffuse;   // sum over frames of the unshadowed diffuse light
uniform sampler2D u_specular;  // ... and specular light; a: sum of the specular lobe's scale s
uniform sampler2D u_ratio;     // (sum V g_d, sum g_d, sum V g_s, sum h_s) over the light's samples
uniform float u_frames;        // frames in the sums of u_diffuse and u_specular

out vec4 out_color;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 r = texelFetch(u_ratio, p, 0);
    vec4 spec = texelFetch(u_specular, p, 0);
    // The specular denominator is sum s h_s: h_s per sample, s the pixel's mean scale over frames.
    float denom_s = r.w * spec.a / u_frames;
    bool has_d = r.y > 0.0;
    bool has_s = denom_s > 0.0;
    float ratio_d = has_d ? r.x / r.y : (has_s ? r.z / denom_s : 1.0);
    float ratio_s = has_s ? r.z / denom_s : ratio_d;
    vec3 c = texelFetch(u_diffuse, p, 0).rgb * ratio_d + spec.rgb * ratio_s;
    out_color = vec4(c / u_frames, 1.0);
}

#endif
