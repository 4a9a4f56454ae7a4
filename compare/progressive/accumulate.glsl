// Running mean of the terms every frame carries (emission, background; later the
// environment): A_n = A_(n-1) + (C_n - A_(n-1)) / n, ping-pong between two RGBA32F
// targets; the first frame (n = 1) overwrites.

#if defined VERTEX_SHADER

void main() {
    // One triangle covering the viewport.
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}

#elif defined FRAGMENT_SHADER

uniform sampler2D u_previous;
uniform sampler2D u_position;  // G-buffer: w = kind, 0 where no surface was hit
uniform sampler2D u_emission;  // G-buffer: emitted radiance towards the camera
uniform vec3 u_background;     // radiance seen where no surface was hit
uniform float u_count;

out vec4 out_color;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec3 c = texelFetch(u_position, p, 0).w > 0.5 ? texelFetch(u_emission, p, 0).rgb : u_background;
    vec3 a = u_count > 1.0 ? texelFetch(u_previous, p, 0).rgb : vec3(0.0);
    out_color = vec4(a + (c - a) / u_count, 1.0);
}

#endif
