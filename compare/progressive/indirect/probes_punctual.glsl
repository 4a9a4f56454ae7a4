// Irradiance-volume bake, step 2 for a point, spot or directional light (probes.py): its direct
// irradiance at every texel of the probes' cube faces, added (blending ONE, ONE) over the area
// lights' samples:
//
//   E += V(x) I e(x) cos_s       (e: punctual_light.glsl's falloff and cone, 1 for a directional light)
//
// for the front side of shaded surfaces (kind 1), exact up to the shadow map. V is the light's own
// shadow map (punctual_shadow.glsl with one light), fitted to the whole scene, since the probes see
// surfaces the camera does not.

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

#define BATCH 1
// punctual_light.glsl's incidence only: its Lambert branch needs no material lobes
#define MATERIALS_DIFFUSE 1
#include "brdf.glsl"
#include "gbuffer_inputs.glsl"
#include "probes_surface.glsl"
#include "punctual_shadow.glsl"
#include "punctual_light.glsl"

uniform sampler2D u_pshadow_map;
uniform float u_kind;          // lights.punctual.KIND_CODES
uniform vec3 u_light_position;
uniform vec3 u_light_direction;
uniform vec3 u_light_intensity;
uniform vec2 u_light_cone;

out vec4 out_irradiance;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 gn = texelFetch(u_normal, p, 0);
    vec4 ga = texelFetch(u_material, p, 0);
    vec3 e = vec3(0.0);
    if (bake_front_surface(gn, ga)) {
        vec3 x = texelFetch(u_position, p, 0).xyz;
        vec3 n = normalize(gn.xyz);
        vec3 l;
        float falloff;
        punctual_incidence(x, u_kind, u_light_position, u_light_direction, u_light_cone, l, falloff);
        float cos_s = dot(n, l);
        if (cos_s > 0.0 && falloff > 0.0) {
            e = u_light_intensity * (falloff * cos_s) * punctual_visibility(u_pshadow_map, 0, x, n, l);
        }
    }
    out_irradiance = vec4(e, 1.0);
}

#endif
