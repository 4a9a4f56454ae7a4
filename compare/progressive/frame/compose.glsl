// Display image: the every-frame running mean (emission, background), plus either the
// direct-light running mean or, before the first light frame, frame 0's unshadowed
// preview, plus the environment light: the unoccluded split sum's running mean (the
// every-frame pass's second target) until both kinds of occlusion samples have run,
// then the two running means of the visible diffuse and specular light (env_occlusion.glsl), or
// (environment shadow maps) the unoccluded mean times the shadow ratio of env_shadows.glsl,
// plus the irradiance volume's indirect light where the renderer has one (indirect.glsl),
// plus the punctual lights' running mean (punctual.glsl) where the scene has them; the glass's mean
// (glass.py) composites over that, and the blended surfaces' running mean (blend.py) over all of it.
// The display after a reduced frame 0 (first_frame.py) composes that frame's own, smaller
// targets, upsampled bilinearly.

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

uniform sampler2D u_base;
uniform sampler2D u_direct;
uniform sampler2D u_env;           // unoccluded environment light (running mean over all frames)
uniform sampler2D u_env_diffuse;   // visible diffuse environment light (running mean over its samples)
uniform sampler2D u_env_specular;  // visible specular environment light
uniform sampler2D u_indirect;      // indirect diffuse light of the irradiance volume (running mean)
uniform float u_direct_scale;  // 1 to add u_direct, 0 when there is no direct light to show
uniform float u_indirect_scale;  // 1 to add u_indirect
uniform sampler2D u_punctual;      // the punctual lights' light (running mean)
uniform float u_punctual_scale;  // 1 to add u_punctual
uniform sampler2D u_blend;         // blended surfaces (blend.py): premultiplied colour, a = transmittance
uniform float u_blend_scale;     // 1 to composite u_blend over the rest
uniform sampler2D u_glass;         // the glass (glass.py): sums of its radiance (rgb) and coverage (a)
uniform float u_glass_scale;     // 1 / the glass frames summed, 0 for none
uniform int u_env_mode;        // 0 no environment, 1 unoccluded, 2 occluded (both kinds have samples),
                               // 3 unoccluded times the environment shadow ratio (env_shadows.glsl)
uniform sampler2D u_env_ratio;    // mode 3: the ratios' sums (sum V g_d, sum g_d, sum V g_s, sum g_s)
uniform sampler2D u_env_weights;  // mode 3: the lobes' unshadowed luminance, summed alike (E_d, E_s), sum g_s^2
#ifndef ENV_SPECULAR_SAMPLES
#error ENV_SPECULAR_SAMPLES comes from accumulate.py (ENV_SPECULAR_SAMPLES) as a define
#endif
uniform vec2 u_upsample;       // (0, 0): sources at the output's size; else 1 / the output's size

out vec4 out_color;

vec3 source(sampler2D s) {
    // Same-size sources are read texel for texel, so the display is exactly the means.
    return u_upsample.x > 0.0 ? texture(s, gl_FragCoord.xy * u_upsample).rgb
                              : texelFetch(s, ivec2(gl_FragCoord.xy), 0).rgb;
}

void main() {
    vec3 c = source(u_base);
    if (u_direct_scale > 0.0) {
        c += u_direct_scale * source(u_direct);
    }
    if (u_env_mode == 1) {
        c += source(u_env);
    } else if (u_env_mode == 2) {
        c += source(u_env_diffuse) + source(u_env_specular);
    } else if (u_env_mode == 3) {
        vec4 sums = texelFetch(u_env_ratio, ivec2(gl_FragCoord.xy), 0);
        vec3 e = texelFetch(u_env_weights, ivec2(gl_FragCoord.xy), 0).rgb;
        float r_d = sums.y > 0.0 ? sums.x / sums.y : 1.0;
        float r_s = sums.w > 0.0 ? sums.z / sums.w : 1.0;
        // Kish's effective sample count of the specular ratio; below ENV_SPECULAR_SAMPLES it is
        // blended towards the diffuse ratio (env_shadows.py)
        float n_eff = e.z > 0.0 ? sums.w * sums.w / e.z : 0.0;
        r_s = mix(r_d, r_s, clamp(n_eff / ENV_SPECULAR_SAMPLES, 0.0, 1.0));
        float ratio = e.x + e.y > 0.0 ? (r_d * e.x + r_s * e.y) / (e.x + e.y) : r_d;
        c += source(u_env) * ratio;
    }
    if (u_indirect_scale > 0.0) {
        c += source(u_indirect);
    }
    if (u_punctual_scale > 0.0) {
        c += source(u_punctual);
    }
    if (u_glass_scale > 0.0) {
        vec4 g = texelFetch(u_glass, ivec2(gl_FragCoord.xy), 0) * u_glass_scale;
        c = g.rgb + (1.0 - g.a) * c;
    }
    if (u_blend_scale > 0.0) {
        vec4 b = texelFetch(u_blend, ivec2(gl_FragCoord.xy), 0);
        c = b.rgb + b.a * c;
    }
    out_color = vec4(c, 1.0);
}

#endif
