// The unshadowed light of one rectangular light in closed form (ltc.glsl), full screen
// over the G-buffer, added to the light's sums of this frame's jittered view: diffuse
// into the first target, specular into the second (ltc.py divides by the frames), whose alpha
// sums the specular lobe's scale (Fresnel x (A + B), averaged over RGB), the factor that the
// shadow ratio's specular denominator (direct.glsl) leaves out.
//
// Defines: MATERIALS_DIFFUSE, and direct.py's area_model_defines for ltc: AREA_MODEL_LTC (always 1
// here), AREA_MODEL_PAPER (always 0), LTC_SIZE and LTC_SHAPE_MAX.

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

#include "brdf.glsl"
#include "layers.glsl"
#include "gbuffer_layers.glsl"
#include "gbuffer_inputs.glsl"

uniform vec3 u_camera_position;
uniform vec3 u_light_center;
uniform vec3 u_light_t;
uniform vec3 u_light_b;
uniform vec3 u_light_n;
uniform vec2 u_light_half;
uniform vec3 u_light_radiance;
uniform float u_light_area;

layout(location = 0) out vec4 out_diffuse;
layout(location = 1) out vec4 out_specular;

#include "area_light.glsl"
#include "ltc.glsl"

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    load_layers(p);
    vec4 gp = texelFetch(u_position, p, 0);
    vec3 diffuse = vec3(0.0);
    vec3 specular = vec3(0.0);
    vec3 spec_scale = vec3(0.0);
    if (gp.w > 0.5 && gp.w < 1.5) {
        vec4 gn = texelFetch(u_normal, p, 0);
        vec4 gm = texelFetch(u_material, p, 0);
        ltc_light_scaled(gp.xyz, normalize(gn.xyz), normalize(u_camera_position - gp.xyz), gm.rgb, gm.a, gn.w,
                         diffuse, specular, spec_scale);
    }
    out_diffuse = vec4(diffuse, 0.0);
    out_specular = vec4(specular, dot(spec_scale, vec3(1.0 / 3.0)));
}

#endif
