// The vertex side of material.glsl: with TEXTURES, the texture coordinates and the tangent pass
// through to the fragment stage (call material_vertex() in main).

#if TEXTURES
in vec2 in_uv;
in vec4 in_tangent;
out vec2 v_uv;
out vec4 v_tangent;

void material_vertex() {
    v_uv = in_uv;
    v_tangent = in_tangent;
}
#else
void material_vertex() {}
#endif
