// Depth-only pass: the scene rasterized at the camera with no shading at all.
// The benchmark uses it as the floor a frame cannot go below (vertex work,
// rasterization and depth writes of the same geometry at the same size).

#if defined VERTEX_SHADER

in vec3 in_position;
#include "material_vertex.glsl"
uniform mat4 u_view_proj;
// The first frame's depth pre-pass and shading pass must agree on depth bit for bit.
invariant gl_Position;

void main() {
    material_vertex();
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}

#elif defined FRAGMENT_SHADER

// With ALPHA_MASK (and TEXTURES), the holes of alpha-masked materials write no depth.
#include "material.glsl"

void main() {
    alpha_test();
    cull_back_face();
}

#endif
