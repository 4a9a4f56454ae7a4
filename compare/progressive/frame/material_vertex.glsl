// The vertex side of material.glsl: with TEXTURES, the texture coordinates (xy TEXCOORD_0, zw TEXCOORD_1)
// and the tangent pass through to the fragment stage; with VERTEX_COLORS, glTF's COLOR_0 (call material_vertex() in main).

#ifndef VERTEX_COLORS
#define VERTEX_COLORS 0
#endif
#if TEXTURES
in vec4 in_uv;
in vec4 in_tangent;
out vec4 v_uv;
out vec4 v_tangent;
#endif
#if VERTEX_COLORS
in vec4 in_color;
out vec4 v_color;
#endif

void material_vertex() {
#if TEXTURES
    v_uv = in_uv;
    v_tangent = in_tangent;
#endif
#if VERTEX_COLORS
    v_color = in_color;
#endif
}
