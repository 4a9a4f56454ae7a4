// The shaded surface's material: the mesh's factors, or, with TEXTURES, its maps where it has
// them. A map replaces its factor, as in the scene model (compare/mitsuba_dict.py does the same):
// the base-colour map holds linear RGB (sRGB decoded when uploaded, then mipmapped), the
// metallic-roughness map glTF's channels (G = roughness, B = metallic). Without TEXTURES the
// three functions are the uniforms, so a scene without textures runs the code it always ran.
// Needs v_uv (the vertex shader's in_uv) with TEXTURES.

uniform vec3 u_base_color;
uniform float u_metallic;
uniform float u_roughness;

#if TEXTURES
in vec2 v_uv;
uniform sampler2D u_base_color_map;
uniform sampler2D u_metallic_roughness_map;
uniform float u_has_base_color_map;          // 1: sample u_base_color_map, 0: u_base_color
uniform float u_has_metallic_roughness_map;

vec3 material_base_color() {
    return u_has_base_color_map > 0.5 ? texture(u_base_color_map, v_uv).rgb : u_base_color;
}
float material_metallic() {
    return u_has_metallic_roughness_map > 0.5 ? texture(u_metallic_roughness_map, v_uv).b : u_metallic;
}
float material_roughness() {
    return u_has_metallic_roughness_map > 0.5 ? texture(u_metallic_roughness_map, v_uv).g : u_roughness;
}
#else
#define material_base_color() u_base_color
#define material_metallic() u_metallic
#define material_roughness() u_roughness
#endif
