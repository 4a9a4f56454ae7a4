// Display image: the every-frame running mean (emission, background), plus either the
// direct-light running mean or, before the first light frame, frame 0's unshadowed
// preview, plus the environment light: the unoccluded split sum's running mean (the
// every-frame pass's second target) until both kinds of occlusion samples have run,
// then the two running means of the visible diffuse and specular light (env_occlusion.glsl),
// plus the irradiance volume's indirect light where the renderer has one (indirect.glsl).

#if defined VERTEX_SHADER

void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}

#elif defined FRAGMENT_SHADER

uniform sampler2D u_base;
uniform sampler2D u_direct;
uniform sampler2D u_env;           // unoccluded environment light (running mean over all frames)
uniform sampler2D u_env_diffuse;   // visible diffuse environment light (running mean over its samples)
uniform sampler2D u_env_specular;  // visible specular environment light
uniform sampler2D u_indirect;      // indirect diffuse light of the irradiance volume (running mean)
uniform float u_direct_scale;  // 1 to add u_direct, 0 when there is no direct light to show
uniform float u_indirect_scale;  // 1 to add u_indirect
uniform int u_env_mode;        // 0 no environment, 1 unoccluded, 2 occluded (both kinds have samples)

out vec4 out_color;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec3 c = texelFetch(u_base, p, 0).rgb;
    if (u_direct_scale > 0.0) {
        c += u_direct_scale * texelFetch(u_direct, p, 0).rgb;
    }
    if (u_env_mode == 1) {
        c += texelFetch(u_env, p, 0).rgb;
    } else if (u_env_mode == 2) {
        c += texelFetch(u_env_diffuse, p, 0).rgb + texelFetch(u_env_specular, p, 0).rgb;
    }
    if (u_indirect_scale > 0.0) {
        c += texelFetch(u_indirect, p, 0).rgb;
    }
    out_color = vec4(c, 1.0);
}

#endif
