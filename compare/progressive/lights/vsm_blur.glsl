// Variance shadow maps: one direction of the separable box filter of the moment atlas
// (shadow.py). Each texel averages the texels of its own face's tile along u_axis; taps
// outside the tile are left out and the weights renormalised, so nothing bleeds
// across the five faces and a tile's border is not over-weighted (as clamp-to-edge
// would). The box has a real-valued width: the two end taps get the fraction of
// their texel that the box covers, so the width varies smoothly with the light.

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

uniform sampler2D u_source;  // RG32F moments (d, d^2)
uniform ivec2 u_axis;        // (1, 0) or (0, 1)
uniform float u_width;       // box width in texels
uniform int u_size;          // face size S: front tile S x S at x < S, side tiles S x S/2

out vec2 out_moments;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    int s = u_size;
    int h = u_size / 2;
    ivec2 lo = ivec2(0);
    ivec2 hi = ivec2(s - 1);
    if (p.x >= s) {
        lo = ivec2(p.x < 2 * s ? s : 2 * s, p.y < h ? 0 : h);
        hi = lo + ivec2(s - 1, h - 1);
    }
    float half_width = 0.5 * u_width;
    int r = int(ceil(half_width - 0.5));
    vec2 sum = vec2(0.0);
    float weight = 0.0;
    // Two taps per bilinear fetch: taps k and k + 1 with weights w0, w1 are one fetch at
    // k + w1 / (w0 + w1) (in texel centres), weighted w0 + w1; a tap outside the tile gets
    // weight 0, so a pair at the tile's border reads its inner texel's centre exactly.
    // Branch-free, because llvmpipe runs divergent branches slowly.
    vec2 axis = vec2(u_axis);
    float p_axis = dot(vec2(p), axis);
    float lo_axis = dot(vec2(lo), axis);
    float hi_axis = dot(vec2(hi), axis);
    vec2 size = vec2(textureSize(u_source, 0));
    for (int i = -r; i <= r; i += 2) {
        float k = p_axis + float(i);
        float w0 = clamp(half_width + 0.5 - abs(float(i)), 0.0, 1.0) * float(k >= lo_axis && k <= hi_axis);
        float w1 = clamp(half_width + 0.5 - abs(float(i + 1)), 0.0, 1.0) * float(i + 1 <= r)
                   * float(k + 1.0 >= lo_axis && k + 1.0 <= hi_axis);
        float w = w0 + w1;
        float at = clamp(k + w1 / max(w, 1e-6), lo_axis, hi_axis) - p_axis;
        sum += w * textureLod(u_source, (vec2(p) + 0.5 + at * axis) / size, 0.0).rg;
        weight += w;
    }
    out_moments = sum / weight;
}

#endif
