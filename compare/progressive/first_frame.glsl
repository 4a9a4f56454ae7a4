// The first frame, forward-shaded: the scene from frame 0's camera straight into the
// targets, without the G-buffer and its full-screen passes (first_frame.py).
//
// out_color:  the every-frame mean's first value, as accumulate.glsl writes it for
//             n = 1: emission, or the background where no surface is seen (with
//             ENVIRONMENT the map, drawn by a full-screen triangle behind the scene;
//             without it the clear colour, black);
// out_env:    (ENVIRONMENT) the unoccluded environment light, the split sum of
//             compare/ibl/ibl.glsl;
// out_direct: the unshadowed direct light of each area light from its centre
//             (light_preview in area_light.glsl), shown until the first light frame;
// out_punctual: (PUNCTUAL > 0) the exact unshadowed light of the punctual lights
//             (punctual_light.glsl), the first value of their running mean (punctual.py).
//
// A depth pre-pass runs first, so each pixel is shaded once.
//
// With BLEND the same shading draws the blend pass instead (blend.py): out_color is the lit colour (emission,
// the unoccluded environment light, each light unshadowed) times the coverage, and the coverage.
//
// With GLASS it draws the glass pass (glass.py): out_color is the glass's whole radiance (that shading, with
// (1 - transmission) of the diffuse lobe, plus the light it lets through, transmission.glsl), and 1. With
// TRANSMISSION alone a reduced frame 0 draws its glass so, the transmitted light seeing the environment map.
//
// With PREVIEW (a reduced frame 0, a preview outside the running means) out_color is the one output: what
// the display adds up from the outputs above (compose.glsl), summed here; one target instead of up to four
// is what a software rasterizer clears and writes per pixel.
//
// Defines: LIGHTS (number of area lights, 0 for none), PUNCTUAL (number of punctual lights), BLEND, GLASS, PREVIEW,
// TRANSMISSION, ENVIRONMENT, AREA_MODEL_PAPER, AREA_MODEL_LTC (the preview is then the closed-form unshadowed
// light, ltc.glsl), MATERIALS_DIFFUSE.

#if defined VERTEX_SHADER

in vec3 in_position;
in vec3 in_normal;
#include "material_vertex.glsl"

uniform mat4 u_view_proj;
// The first frame's depth pre-pass and shading pass must agree on depth bit for bit.
invariant gl_Position;
uniform float u_background_pass;  // 1: the full-screen background triangle at the far plane

out vec3 v_position;
out vec3 v_normal;

void main() {
    v_position = in_position;
    v_normal = in_normal;
    material_vertex();
    if (u_background_pass > 0.5) {
        vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
        gl_Position = vec4(p * 2.0 - 1.0, 1.0, 1.0);
    } else {
        gl_Position = u_view_proj * vec4(in_position, 1.0);
    }
}

#elif defined FRAGMENT_SHADER

#include "brdf.glsl"
#if ENVIRONMENT
#include "mapping.glsl"
#include "ibl.glsl"
uniform mat4 u_inv_view_proj;
uniform vec2 u_viewport;
#endif
#include "layers.glsl"
#ifndef GLASS
#define GLASS 0
#endif
#ifndef PREVIEW
#define PREVIEW 0
#endif
#ifndef TRANSMISSION
#define TRANSMISSION GLASS
#endif

in vec3 v_position;
in vec3 v_normal;

#include "material.glsl"

uniform vec3 u_camera_position;
uniform float u_kind;             // 1 = shaded surface, 2 = emitter that reflects nothing
uniform float u_background_pass;

layout(location = 0) out vec4 out_color;
#if BLEND || GLASS
// The blend pass (blend.py): one output, the lit colour premultiplied by the coverage, and the
// coverage; the glass pass: the glass's radiance, and 1; depth against the G-buffer's nearest opaque surface.
uniform float u_blend_alpha;     // glTF's alpha (times the base-colour map's)
uniform sampler2D u_gbuffer_position;
#if GLASS
uniform float u_glass_preview;   // 1: frame 0 drawn forward (glass.py): no G-buffer, the depth test hides the glass
#define GBUFFER_READ (u_glass_preview < 0.5)
#else
#define GBUFFER_READ true
#endif
#elif PREVIEW
#elif ENVIRONMENT
layout(location = 1) out vec4 out_env;
layout(location = 2) out vec4 out_direct;
#if PUNCTUAL > 0
layout(location = 3) out vec4 out_punctual;
#endif
#else
layout(location = 1) out vec4 out_direct;
#if PUNCTUAL > 0
layout(location = 2) out vec4 out_punctual;
#endif
#endif

#if PUNCTUAL > 0
#include "punctual_light.glsl"
uniform float u_punctual_kind[PUNCTUAL];
uniform vec3 u_punctual_position[PUNCTUAL];
uniform vec3 u_punctual_direction[PUNCTUAL];
uniform vec3 u_punctual_intensity[PUNCTUAL];
uniform vec2 u_punctual_cone[PUNCTUAL];
#endif

#if TRANSMISSION
#include "transmission.glsl"
#endif

#if LIGHTS > 0
uniform vec3 u_lights_center[LIGHTS];
uniform vec3 u_lights_t[LIGHTS];
uniform vec3 u_lights_b[LIGHTS];
uniform vec3 u_lights_n[LIGHTS];
uniform vec2 u_lights_half[LIGHTS];
uniform vec3 u_lights_radiance[LIGHTS];
uniform float u_lights_area[LIGHTS];

// area_light.glsl reads the current light from these; the loop below sets them.
vec3 u_light_center;
vec3 u_light_t;
vec3 u_light_b;
vec3 u_light_n;
vec2 u_light_half;
vec3 u_light_radiance;
float u_light_area;
#include "area_light.glsl"
#include "ltc.glsl"
#endif

void main() {
#if ENVIRONMENT
    if (u_background_pass > 0.5) {
        out_color = vec4(env_background_at_pixel(gl_FragCoord.xy, u_viewport, u_inv_view_proj), 1.0);
#if !BLEND && !GLASS && !PREVIEW
        out_env = vec4(0.0, 0.0, 0.0, 1.0);
        out_direct = vec4(0.0, 0.0, 0.0, 1.0);
#if PUNCTUAL > 0
        out_punctual = vec4(0.0, 0.0, 0.0, 1.0);
#endif
#endif
        return;
    }
#endif
    alpha_test();
    cull_back_face();
#if BLEND || GLASS
    // behind the nearest opaque surface (the G-buffer's, a hair of tolerance): hidden
    vec4 opaque = texelFetch(u_gbuffer_position, ivec2(gl_FragCoord.xy), 0);
    if (GBUFFER_READ && opaque.w > 0.5 && distance(opaque.xyz, u_camera_position)
                           < distance(v_position, u_camera_position) * (1.0 - 1e-5)) {
        discard;
    }
#endif
    vec3 n = normalize(v_normal);
    vec3 v = normalize(u_camera_position - v_position);
    vec3 c = dot(n, v) > 0.0 ? material_emission() : vec3(0.0);
    n = facing_normal(n);
    vec3 direct = vec3(0.0);
    vec3 env = vec3(0.0);
    vec3 punctual = vec3(0.0);
    if (u_kind < 1.5) {
        n = material_normal(n);
        vec3 base_color = material_base_color();
        float metallic = material_metallic();
        float roughness = material_roughness();
#if LAYERS
        g_layers = MaterialLayers(material_layer_f0(), material_layer_weight(), material_clearcoat(),
                                  material_clearcoat_roughness(), material_sheen_color(), material_sheen_roughness());
#endif
#if TRANSMISSION
        // glTF's mix of the diffuse base and the transmission: the dielectric part's share that is glass
        float transmission = material_transmission(u_transmission);
        float glass = transmission * (1.0 - clamp(metallic, 0.0, 1.0));
        vec3 tint = base_color;
        if (glass > 0.0) {
            env += glass * glass_transmitted(v_position, n, v, tint, roughness);
            // the lights below light the diffuse lobe's remaining share, (1 - transmission) of the dielectric
            // part's, and the metal's Fresnel its base colour: exact where metallic is 0 or 1 (a map's texels),
            // the two mixed by the filtered metallic between
            base_color *= 1.0 - glass;
        }
#endif
#if ENVIRONMENT
        vec3 diffuse;
        vec3 specular;
        env_split_sum_material(n, v, base_color, metallic, roughness, diffuse, specular);
        env += (diffuse + specular) * material_occlusion();
#endif
#if LIGHTS > 0
        for (int i = 0; i < LIGHTS; ++i) {
            u_light_center = u_lights_center[i];
            u_light_t = u_lights_t[i];
            u_light_b = u_lights_b[i];
            u_light_n = u_lights_n[i];
            u_light_half = u_lights_half[i];
            u_light_radiance = u_lights_radiance[i];
            u_light_area = u_lights_area[i];
            direct += light_preview(v_position, n, v, base_color, metallic, roughness);
        }
#endif
#if PUNCTUAL > 0
        for (int i = 0; i < PUNCTUAL; ++i) {
            punctual += punctual_radiance(v_position, n, v, base_color, metallic, roughness, u_punctual_kind[i],
                                          u_punctual_position[i], u_punctual_direction[i],
                                          u_punctual_intensity[i], u_punctual_cone[i]);
        }
#endif
    }
#if BLEND
    float coverage = u_blend_alpha;
#if TEXTURES
    coverage *= HAS_BASE_COLOR_MAP ? sample_map(u_base_color_map, 0).a : 1.0;
#endif
    coverage *= VERTEX_ALPHA;
    out_color = vec4((c + env + direct + punctual) * coverage, coverage);
#elif GLASS
    out_color = vec4(c + env + direct + punctual, 1.0);
#elif PREVIEW
    // compose.glsl's order; clamped to the half-float target's largest value (a sun seen directly): a driver
    // may turn an overflow into inf
    out_color = vec4(min(c + direct + env + punctual, vec3(65504.0)), 1.0);
#else
    out_color = vec4(c, 1.0);
#if ENVIRONMENT
    out_env = vec4(env, 1.0);
#endif
    out_direct = vec4(direct, 1.0);
#if PUNCTUAL > 0
    out_punctual = vec4(punctual, 1.0);
#endif
#endif
}

#endif
