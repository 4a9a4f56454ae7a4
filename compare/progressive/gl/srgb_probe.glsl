// What this OpenGL's sampler returns for each code of an sRGB8 texture: one texel per fragment,
// fetched unfiltered, written as float. The maps' sRGB decode is the driver's (exact on GPUs, an
// approximation on some software rasterizers); compare.progressive.gl.srgb_probe measures it.

#if defined VERTEX_SHADER

in vec2 in_position;

void main() {
    gl_Position = vec4(in_position, 0.0, 1.0);
}

#elif defined FRAGMENT_SHADER

uniform sampler2D u_codes;
out vec4 out_value;

void main() {
    out_value = texelFetch(u_codes, ivec2(int(gl_FragCoord.x), 0), 0);
}

#endif
