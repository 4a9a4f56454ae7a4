// Irradiance-volume bake, step 2: direct irradiance from one area-light sample at every texel
// of the probes' cube faces, added (blending ONE, ONE) over the light samples.
//
//   E += V(x, y) L (A / n) cos_s cos_l / |y - x|^2         (radiometric point-on-area estimate)
//
// for the front side of shaded surfaces (kind 1); y is the sample point, n the samples of the
// light. V is the hard shadow test of ShadowAtlas's five-face depth atlas, shadow_test.glsl,
// the same test as the direct-light pass's (normal offset, constant and slope bias in shadow
// texels).

#if defined VERTEX_SHADER

#include "fullscreen.glsl"

#elif defined FRAGMENT_SHADER

#include "gbuffer_inputs.glsl"
#include "probes_surface.glsl"

uniform vec3 u_light_center;
uniform vec3 u_light_t;
uniform vec3 u_light_b;
uniform vec3 u_light_n;
uniform vec3 u_light_radiance;
uniform float u_light_area;
uniform vec3 u_sample;
uniform float u_weight;        // 1 / n

#include "shadow_test.glsl"

out vec4 out_irradiance;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 gn = texelFetch(u_normal, p, 0);
    vec4 ga = texelFetch(u_material, p, 0);
    vec3 e = vec3(0.0);
    if (bake_front_surface(gn, ga)) {
        vec3 x = texelFetch(u_position, p, 0).xyz;
        vec3 n = normalize(gn.xyz);
        vec3 to_y = u_sample - x;
        float d2 = max(dot(to_y, to_y), 1e-12);
        vec3 l = to_y * inversesqrt(d2);
        float cos_s = dot(n, l);
        float cos_l = -dot(u_light_n, l);
        if (cos_s > 0.0 && cos_l > 0.0 && dot(x - u_light_center, u_light_n) > 0.0) {
            e = u_light_radiance * (u_weight * u_light_area * cos_s * cos_l / d2) * visibility(x, n);
        }
    }
    out_irradiance = vec4(e, 1.0);
}

#endif
