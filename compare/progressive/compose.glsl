// Display image: the every-frame running mean plus either the direct-light running
// mean or, before the first light frame, frame 0's unshadowed preview.

#if defined VERTEX_SHADER

void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}

#elif defined FRAGMENT_SHADER

uniform sampler2D u_base;
uniform sampler2D u_direct;
uniform float u_direct_scale;  // 1 to add u_direct, 0 when there is no direct light to show

out vec4 out_color;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec3 c = texelFetch(u_base, p, 0).rgb;
    if (u_direct_scale > 0.0) {
        c += u_direct_scale * texelFetch(u_direct, p, 0).rgb;
    }
    out_color = vec4(c, 1.0);
}

#endif
