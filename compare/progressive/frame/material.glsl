// The shaded surface's material: the mesh's factors, or, with TEXTURES, its maps where it has
// them. A map replaces its factor, as in the scene model (compare/mitsuba/scene_dict.py does the same):
// the base-colour map holds linear RGB (sRGB decoded when uploaded, then mipmapped), the
// metallic-roughness map glTF's channels (G = roughness, B = metallic); the emission map (sRGB
// too) multiplies the emission, as glTF's emissiveTexture does. Without TEXTURES the
// three functions are the uniforms, so a scene without textures runs the code it always ran.
// Needs v_uv (the vertex shader's in_uv) with TEXTURES.
//
// ALPHA_MASK (with TEXTURES; both always defined, 0 or 1): alpha_test() discards the fragments
// where glTF's coverage, u_alpha times the base-colour map's alpha, is below u_alpha_cutoff (a
// negative cutoff: an opaque mesh; the occluder passes draw opaque meshes with a program without it). Every pass that rasterizes the scene calls it first (G-buffer,
// forward first frame and its depth pre-pass, probe bake, shadow maps), so a hole is one for
// camera rays and light alike. The test is on the filtered alpha, as GPUs do it.

// VERTEX_COLORS (always defined, 0 or 1): glTF's COLOR_0 (material_vertex.glsl's v_color) multiplies
// the base colour and the alpha; without it the factors are 1 and the code is what it always was.
#ifndef VERTEX_COLORS
#define VERTEX_COLORS 0
#endif
#if VERTEX_COLORS
in vec4 v_color;
#define VERTEX_RGB v_color.rgb
#define VERTEX_ALPHA v_color.a
#else
#define VERTEX_RGB vec3(1.0)
#define VERTEX_ALPHA 1.0
#endif

uniform vec3 u_base_color;
uniform float u_metallic;

// glTF's doubleSided, per mesh: 2 (double-sided) shades a back face with its normal turned to the viewer;
// 1 (single-sided) culls it: cull_back_face() discards it in the passes of camera rays (G-buffer, first
// frame, its depth pre-pass); shadow maps and the probes' bake draw every face.
// FACE_CULLING 1: the pass culls with GL's face culling instead (GpuScene's draws with cull=True), the same
// faces: a shader that can discard costs llvmpipe on every fragment, a whole program dearer, even where it
// never discards (docs/performance-notes.md).
#ifndef FACE_CULLING
#define FACE_CULLING 0
#endif
#if FACE_CULLING
void cull_back_face() {}
#else
uniform float u_sides;
void cull_back_face() {
    if (u_sides < 1.5 && !gl_FrontFacing) {
        discard;
    }
}
#endif
vec3 facing_normal(vec3 n) {
    return gl_FrontFacing ? n : -n;
}
uniform float u_roughness;
uniform vec3 u_emission;   // radiance leaving the front side (the side the normal faces)

#ifndef LAYERS
#define LAYERS 0
#endif
#if LAYERS
// glTF's layers (layers.glsl): the factors, times the extensions' maps where the mesh has them (with
// TEXTURES; material_layer_*() below).
uniform vec3 u_layer_f0;
uniform float u_layer_weight;
uniform float u_clearcoat;
uniform float u_clearcoat_roughness;
uniform vec3 u_sheen_color;
uniform float u_sheen_roughness;
#endif

#if TEXTURES
// Whether the mesh has each map: the uniforms, or, in a program specialised for one set of maps (the
// G-buffer's, gpu_scene.map_set_defines), constants that fold the absent lookups away (a software
// rasterizer runs both sides of a uniform branch).
#ifndef HAS_BASE_COLOR_MAP
#define HAS_BASE_COLOR_MAP (u_has_base_color_map > 0.5)
#endif
#ifndef HAS_METALLIC_ROUGHNESS_MAP
#define HAS_METALLIC_ROUGHNESS_MAP (u_has_metallic_roughness_map > 0.5)
#endif
#ifndef HAS_EMISSION_MAP
#define HAS_EMISSION_MAP (u_has_emission_map > 0.5)
#endif
#ifndef HAS_OCCLUSION_MAP
#define HAS_OCCLUSION_MAP (u_has_occlusion_map > 0.5)
#endif
#ifndef HAS_NORMAL_MAP
#define HAS_NORMAL_MAP (u_has_normal_map > 0.5)
#endif
#ifndef IS_MASKED
#define IS_MASKED (u_alpha_cutoff >= 0.0)
#endif
// The extensions' maps (MAP_SLOTS 5 to 11), each multiplying its factor: transmission (R), clearcoat (R),
// clearcoat roughness (G), sheen colour (RGB, sRGB), sheen roughness (A), specular (A), specular colour (RGB,
// sRGB; it multiplies the F0 of the ior and the colour factor, clamped at 1 as the reference's).
#ifndef HAS_TRANSMISSION_MAP
#define HAS_TRANSMISSION_MAP (u_has_transmission_map > 0.5)
#endif
#ifndef HAS_CLEARCOAT_MAP
#define HAS_CLEARCOAT_MAP (u_has_clearcoat_map > 0.5)
#endif
#ifndef HAS_CLEARCOAT_ROUGHNESS_MAP
#define HAS_CLEARCOAT_ROUGHNESS_MAP (u_has_clearcoat_roughness_map > 0.5)
#endif
#ifndef HAS_SHEEN_COLOR_MAP
#define HAS_SHEEN_COLOR_MAP (u_has_sheen_color_map > 0.5)
#endif
#ifndef HAS_SHEEN_ROUGHNESS_MAP
#define HAS_SHEEN_ROUGHNESS_MAP (u_has_sheen_roughness_map > 0.5)
#endif
#ifndef HAS_SPECULAR_MAP
#define HAS_SPECULAR_MAP (u_has_specular_map > 0.5)
#endif
#ifndef HAS_SPECULAR_COLOR_MAP
#define HAS_SPECULAR_COLOR_MAP (u_has_specular_color_map > 0.5)
#endif
uniform sampler2D u_transmission_map;
uniform sampler2D u_clearcoat_map;
uniform sampler2D u_clearcoat_roughness_map;
uniform sampler2D u_sheen_color_map;
uniform sampler2D u_sheen_roughness_map;
uniform sampler2D u_specular_map;
uniform sampler2D u_specular_color_map;
uniform float u_has_transmission_map;
uniform float u_has_clearcoat_map;
uniform float u_has_clearcoat_roughness_map;
uniform float u_has_sheen_color_map;
uniform float u_has_sheen_roughness_map;
uniform float u_has_specular_map;
uniform float u_has_specular_color_map;
in vec4 v_uv;                                // xy: TEXCOORD_0, zw: TEXCOORD_1
in vec4 v_tangent;                           // glTF tangent: xyz along +u, w: sign of the bitangent
// Per map (the slots of MAP_SLOTS: base colour, metallic-roughness, emission, occlusion, normal): its
// KHR_texture_transform, and (its texture coordinate set, wrap along s, wrap along t; 0 repeat, 1 clamp,
// 2 mirror)
#ifndef MAP_SLOT_COUNT
#error MAP_SLOT_COUNT comes from gpu_scene.py (MAP_SLOTS) as a define
#endif
uniform mat3 u_map_transform[MAP_SLOT_COUNT];
uniform vec3 u_map_read[MAP_SLOT_COUNT];
uniform sampler2D u_base_color_map;
uniform sampler2D u_metallic_roughness_map;
uniform float u_has_base_color_map;          // 1: sample u_base_color_map, 0: u_base_color
uniform float u_has_metallic_roughness_map;
uniform sampler2D u_emission_map;            // linear RGB, multiplied by u_emission
uniform float u_has_emission_map;
uniform sampler2D u_normal_map;              // glTF: tangent space, +Y up the image
uniform float u_has_normal_map;
uniform float u_normal_scale;
uniform sampler2D u_occlusion_map;           // glTF: R, linear
uniform float u_has_occlusion_map;
uniform float u_occlusion_strength;

// Texture coordinates wrapped here for "mirror" (the samplers repeat for "repeat" and clamp
// otherwise, which at a mirror's seam is what mirroring gives), with the derivatives of the
// unwrapped coordinates, so that mip levels do not jump at the seams.
vec4 sample_map(sampler2D map, int slot) {
    vec3 read = u_map_read[slot];
    vec2 uv = (u_map_transform[slot] * vec3(read.x > 0.5 ? v_uv.zw : v_uv.xy, 1.0)).xy;
    vec2 dx = dFdx(uv);
    vec2 dy = dFdy(uv);
    vec2 mirrored = 1.0 - abs(mod(uv, 2.0) - 1.0);
    uv = vec2(read.y > 1.5 ? mirrored.x : uv.x, read.z > 1.5 ? mirrored.y : uv.y);
    return textureGrad(map, uv, dx, dy);
}
vec3 material_base_color() {
    return (HAS_BASE_COLOR_MAP ? sample_map(u_base_color_map, 0).rgb : u_base_color) * VERTEX_RGB;
}
float material_metallic() {
    return HAS_METALLIC_ROUGHNESS_MAP ? sample_map(u_metallic_roughness_map, 1).b : u_metallic;
}
float material_roughness() {
    return HAS_METALLIC_ROUGHNESS_MAP ? sample_map(u_metallic_roughness_map, 1).g : u_roughness;
}
vec3 material_emission() {
    return HAS_EMISSION_MAP ? u_emission * sample_map(u_emission_map, 2).rgb : u_emission;
}
// glTF's occlusion: 1 + strength (map - 1), the factor on ambient and indirect light (1 without a map).
float material_occlusion() {
    return HAS_OCCLUSION_MAP ? 1.0 + u_occlusion_strength * (sample_map(u_occlusion_map, 3).r - 1.0) : 1.0;
}
// The shading normal: the normal map's in the frame (tangent, bitangent = cross(n, tangent) w, n).
vec3 material_normal(vec3 n) {
    if (!HAS_NORMAL_MAP) {
        return n;
    }
    vec3 t = normalize(v_tangent.xyz - n * dot(n, v_tangent.xyz));
    vec3 b = cross(n, t) * (v_tangent.w < 0.0 ? -1.0 : 1.0);
    vec3 c = sample_map(u_normal_map, 4).xyz * 2.0 - 1.0;
    c.xy *= u_normal_scale;
    return normalize(t * c.x + b * c.y + n * c.z);
}
#if ALPHA_MASK
uniform float u_alpha;
uniform float u_alpha_cutoff;
void alpha_test() {
    if (IS_MASKED) {
        float a = u_alpha * (HAS_BASE_COLOR_MAP ? sample_map(u_base_color_map, 0).a : 1.0) * VERTEX_ALPHA;
        if (a < u_alpha_cutoff) {
            discard;
        }
    }
}
#else
void alpha_test() {}
#endif
// The layers' values at the fragment (the G-buffer's layer targets, frame 0's g_layers).
#if LAYERS
vec3 material_layer_f0() {
    return HAS_SPECULAR_COLOR_MAP ? min(u_layer_f0 * sample_map(u_specular_color_map, 11).rgb, vec3(1.0))
                                  : u_layer_f0;
}
float material_layer_weight() {
    return HAS_SPECULAR_MAP ? u_layer_weight * sample_map(u_specular_map, 10).a : u_layer_weight;
}
float material_clearcoat() {
    return HAS_CLEARCOAT_MAP ? u_clearcoat * sample_map(u_clearcoat_map, 6).r : u_clearcoat;
}
float material_clearcoat_roughness() {
    return HAS_CLEARCOAT_ROUGHNESS_MAP ? u_clearcoat_roughness * sample_map(u_clearcoat_roughness_map, 7).g
                                       : u_clearcoat_roughness;
}
vec3 material_sheen_color() {
    return HAS_SHEEN_COLOR_MAP ? u_sheen_color * sample_map(u_sheen_color_map, 8).rgb : u_sheen_color;
}
float material_sheen_roughness() {
    return HAS_SHEEN_ROUGHNESS_MAP ? u_sheen_roughness * sample_map(u_sheen_roughness_map, 9).a : u_sheen_roughness;
}
#endif
// glTF's transmission factor times its map (R); ``factor`` the mesh's (transmission.glsl's u_transmission).
float material_transmission(float factor) {
    return HAS_TRANSMISSION_MAP ? factor * sample_map(u_transmission_map, 5).r : factor;
}
#else
void alpha_test() {}
#define material_transmission(factor) (factor)
#define material_layer_f0() u_layer_f0
#define material_layer_weight() u_layer_weight
#define material_clearcoat() u_clearcoat
#define material_clearcoat_roughness() u_clearcoat_roughness
#define material_sheen_color() u_sheen_color
#define material_sheen_roughness() u_sheen_roughness
#define material_normal(n) (n)
#define material_emission() u_emission
#define material_occlusion() 1.0
#define material_base_color() (u_base_color * VERTEX_RGB)
#define material_metallic() u_metallic
#define material_roughness() u_roughness
#endif
