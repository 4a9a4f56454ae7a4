// G-buffer pass: the scene seen from the jittered camera, one fragment per pixel.
//
// Every later pass of the frame is a full-screen pass reading these targets, so the
// geometry is rasterized once per frame however many light samples the frame has.
// Area-light quads are drawn here too (kind 2): they show their radiance on the
// front side, black behind, and reflect nothing, like the reference's emitters.

#if defined VERTEX_SHADER

#include "world_vertex.glsl"
#include "material_vertex.glsl"

void main() {
    world_vertex();
    material_vertex();
}

#elif defined FRAGMENT_SHADER

in vec3 v_position;
in vec3 v_normal;

#include "material.glsl"

uniform vec3 u_camera_position;
uniform float u_kind;      // 1 = shaded surface, 2 = emitter that reflects nothing

layout(location = 0) out vec4 out_position;  // world position, w = kind (0 = background)
layout(location = 1) out vec4 out_normal;    // unit shading normal, w = perceptual roughness
layout(location = 2) out vec4 out_material;  // base colour, a = metallic
layout(location = 3) out vec4 out_emission;  // emitted radiance towards the camera, a = occlusion
#if LAYERS
layout(location = 4) out vec4 out_layer_f0;     // dielectric F0, a = specular weight (layers.glsl)
layout(location = 5) out vec4 out_layer_coat;   // clearcoat, its roughness
layout(location = 6) out vec4 out_layer_sheen;  // sheen colour, a = sheen roughness
#endif

void main() {
    alpha_test();
    cull_back_face();
    vec3 n = normalize(v_normal);
    bool front = dot(n, u_camera_position - v_position) > 0.0;
    n = facing_normal(n);
    out_position = vec4(v_position, u_kind);
    out_normal = vec4(material_normal(n), material_roughness());
    out_material = vec4(material_base_color(), material_metallic());
    out_emission = vec4(front ? material_emission() : vec3(0.0), material_occlusion());
#if LAYERS
    out_layer_f0 = vec4(material_layer_f0(), material_layer_weight());
    out_layer_coat = vec4(material_clearcoat(), material_clearcoat_roughness(), 0.0, 0.0);
    out_layer_sheen = vec4(material_sheen_color(), material_sheen_roughness());
#endif
}

#endif
