// Irradiance-volume bake, step 3 (once per bounce): the radiance every cube-face texel sees.
//
//   surface    L = emission + albedo / pi * (E_direct + E_previous(x, n))     front of kind 1
//              L = 0                                    back faces, light quads (kind 2)
//   background L_env(direction of the texel)            where the face saw no surface (ENVIRONMENT)
//
// albedo = (1 - metallic) base colour (diffuse only: no specular bounce). E_previous is the
// previous bounce's grid (with the environment the probes saw), looked up with the same
// leak-limited interpolation as the final image (probes.glsl), seen from the probe.
// Light quads are black because the direct-light pass already draws their light; the
// background goes to its own target, since the final grid leaves it out (probes.py).

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

#include "mapping.glsl"
#if ENVIRONMENT
#include "brdf.glsl"
#include "ibl.glsl"
#endif
#include "probes.glsl"

#include "gbuffer_inputs.glsl"
#include "probes_surface.glsl"

uniform sampler2D u_direct;    // direct irradiance (probes_direct.glsl)
uniform int u_previous;        // 1: add E_previous from the grid bound as u_probe_*
uniform int u_tiles;           // probes per atlas row (each 6 faces wide)
uniform float u_face;          // face size S in texels
uniform vec3 u_face_a[6];
uniform vec3 u_face_u[6];
uniform vec3 u_face_v[6];

layout(location = 0) out vec4 out_surface;
layout(location = 1) out vec4 out_background;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 gn = texelFetch(u_normal, p, 0);
    vec3 surface = vec3(0.0);
    vec3 background = vec3(0.0);
    if (gn.w > 0.5) {
        vec4 ga = texelFetch(u_material, p, 0);
        if (bake_front_surface(gn, ga)) {
            vec3 x = texelFetch(u_position, p, 0).xyz;
            vec3 n = normalize(gn.xyz);
            vec3 e = texelFetch(u_direct, p, 0).rgb;
            if (u_previous == 1) {
                int tile = p.x / int(u_face);
                int probe = (p.y / int(u_face)) * u_tiles + tile / 6;
                ivec3 idx = ivec3(probe % u_probe_counts.x, (probe / u_probe_counts.x) % u_probe_counts.y,
                                  probe / (u_probe_counts.x * u_probe_counts.y));
                vec3 c = u_probe_origin + vec3(idx) * u_probe_spacing;
                e += probe_irradiance(x, n, normalize(c - x));
            }
            surface = texelFetch(u_emission, p, 0).rgb + ga.rgb * e * (1.0 / 3.14159265358979323846);
        }
    } else {
#if ENVIRONMENT
        int face = (p.x / int(u_face)) % 6;
        vec2 st = (vec2(p % ivec2(int(u_face))) + 0.5) / u_face * 2.0 - 1.0;
        background = env_background(u_face_a[face] + st.x * u_face_u[face] + st.y * u_face_v[face]);
#endif
    }
    out_surface = vec4(surface, 1.0);
    out_background = vec4(background, 1.0);
}

#endif
