// Indirect diffuse light of the irradiance volume (probes.glsl), full screen over the
// G-buffer, folded into its own running mean A_n = A_(n-1) + (C_n - A_(n-1)) / n.
//
// The volume's light is smooth and needs no samples: the mean only anti-aliases it over
// the jittered frames, so renderer.py runs this pass in the first few frames and then
// keeps the mean (indirect.py says why and how many).

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

#include "brdf.glsl"
#include "mapping.glsl"
#include "probes.glsl"
#include "gbuffer_inputs.glsl"

uniform sampler2D u_previous;
uniform vec3 u_camera_position;
uniform float u_count;

out vec4 out_color;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 gp = texelFetch(u_position, p, 0);
    vec3 c = vec3(0.0);
    if (gp.w > 0.5 && gp.w < 1.5) {  // shaded surfaces only; light quads reflect nothing
        vec4 gn = texelFetch(u_normal, p, 0);
        vec4 gm = texelFetch(u_material, p, 0);
        c = probe_diffuse(gp.xyz, normalize(gn.xyz), normalize(u_camera_position - gp.xyz), gm.rgb, gm.a, gn.w);
#if OCCLUSION
        c *= texelFetch(u_emission, p, 0).a;  // the occlusion map's factor (gbuffer.glsl)
#endif
    }
    vec3 a = u_count > 1.0 ? texelFetch(u_previous, p, 0).rgb : vec3(0.0);
    out_color = vec4(a + (c - a) / u_count, 1.0);
}

#endif
