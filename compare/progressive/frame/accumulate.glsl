// Running mean of the terms every frame carries: A_n = A_(n-1) + (C_n - A_(n-1)) / n,
// ping-pong between two RGBA32F targets; the first frame (n = 1) overwrites.
//
// C_n is the emission of the surface seen through the pixel, or the background where
// no surface was hit. With ENVIRONMENT the background is the environment map towards
// the pixel's (jittered) ray (with BACKGROUND 0, a hidden one: u_background, black), and
// a second target holds the running mean of the unoccluded environment light of shaded
// surfaces (compare/ibl/ibl.glsl: split-sum specular + diffuse irradiance): the cheap
// environment-only image of frame 0, shown until the occlusion samples of env_occlusion.glsl
// take over (compose.glsl).

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

#include "gbuffer_inputs.glsl"

#if ENVIRONMENT
#include "brdf.glsl"
#include "mapping.glsl"
#include "ibl.glsl"
#include "layers.glsl"
#include "gbuffer_layers.glsl"

uniform sampler2D u_previous_env;
uniform mat4 u_inv_view_proj;  // of this frame's jittered camera
uniform vec3 u_camera_position;
uniform vec2 u_viewport;

layout(location = 1) out vec4 out_env;
#endif

uniform sampler2D u_previous;
uniform vec3 u_background;     // radiance seen where no surface was hit (without ENVIRONMENT or BACKGROUND)
uniform float u_count;

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 gp = texelFetch(u_position, p, 0);
    vec3 c;
#if ENVIRONMENT
    vec3 env = vec3(0.0);
#endif
    if (gp.w > 0.5) {
        c = texelFetch(u_emission, p, 0).rgb;
#if ENVIRONMENT
        if (gp.w < 1.5) {  // shaded surface (kind 1); light quads (kind 2) reflect nothing
            vec4 gn = texelFetch(u_normal, p, 0);
            vec4 gm = texelFetch(u_material, p, 0);
            load_layers(p);
            vec3 diffuse;
            vec3 specular;
            env_split_sum_material(normalize(gn.xyz), normalize(u_camera_position - gp.xyz), gm.rgb, gm.a, gn.w,
                                   diffuse, specular);
            env = diffuse + specular;
#if OCCLUSION
            env *= texelFetch(u_emission, p, 0).a;  // the occlusion map's factor (gbuffer.glsl)
#endif
        }
#endif
    } else {
#if ENVIRONMENT && BACKGROUND
        c = env_background_at_pixel(gl_FragCoord.xy, u_viewport, u_inv_view_proj);
#else
        c = u_background;
#endif
    }
    vec3 a = u_count > 1.0 ? texelFetch(u_previous, p, 0).rgb : vec3(0.0);
    out_color = vec4(a + (c - a) / u_count, 1.0);
#if ENVIRONMENT
    vec3 e = u_count > 1.0 ? texelFetch(u_previous_env, p, 0).rgb : vec3(0.0);
    out_env = vec4(e + (env - e) / u_count, 1.0);
#endif
}

#endif
