// The shaded surface's material: the mesh's factors, or, with TEXTURES, its maps where it has
// them. A map replaces its factor, as in the scene model (compare/mitsuba_dict.py does the same):
// the base-colour map holds linear RGB (sRGB decoded when uploaded, then mipmapped), the
// metallic-roughness map glTF's channels (G = roughness, B = metallic); the emission map (sRGB
// too) multiplies the emission, as glTF's emissiveTexture does. Without TEXTURES the
// three functions are the uniforms, so a scene without textures runs the code it always ran.
// Needs v_uv (the vertex shader's in_uv) with TEXTURES.

uniform vec3 u_base_color;
uniform float u_metallic;
uniform float u_roughness;
uniform vec3 u_emission;   // radiance leaving the front side (the side the normal faces)

#if TEXTURES
in vec2 v_uv;
uniform sampler2D u_base_color_map;
uniform sampler2D u_metallic_roughness_map;
uniform float u_has_base_color_map;          // 1: sample u_base_color_map, 0: u_base_color
uniform float u_has_metallic_roughness_map;
uniform sampler2D u_emission_map;            // linear RGB, multiplied by u_emission
uniform float u_has_emission_map;

vec3 material_base_color() {
    return u_has_base_color_map > 0.5 ? texture(u_base_color_map, v_uv).rgb : u_base_color;
}
float material_metallic() {
    return u_has_metallic_roughness_map > 0.5 ? texture(u_metallic_roughness_map, v_uv).b : u_metallic;
}
float material_roughness() {
    return u_has_metallic_roughness_map > 0.5 ? texture(u_metallic_roughness_map, v_uv).g : u_roughness;
}
vec3 material_emission() {
    return u_has_emission_map > 0.5 ? u_emission * texture(u_emission_map, v_uv).rgb : u_emission;
}
#else
#define material_emission() u_emission
#define material_base_color() u_base_color
#define material_metallic() u_metallic
#define material_roughness() u_roughness
#endif
