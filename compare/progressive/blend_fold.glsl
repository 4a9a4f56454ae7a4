// Running mean of the blend pass's frames (blend.py): A_n = A_(n-1) + (C_n - A_(n-1)) / n over the
// premultiplied colour of the blended surfaces (rgb) and the transmittance they leave (a).

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

uniform sampler2D u_previous;
uniform sampler2D u_frame;
uniform float u_count;

out vec4 out_color;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(u_frame, p, 0);
    vec4 a = u_count > 1.0 ? texelFetch(u_previous, p, 0) : vec4(0.0);
    out_color = a + (c - a) / u_count;
}

#endif
