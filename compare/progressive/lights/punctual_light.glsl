// The unshadowed light of one punctual light (KHR_lights_punctual) at a surface point: the math
// shared by the punctual pass (punctual.glsl, with its shadow map) and the forward-shaded first
// frame (first_frame.glsl). The includer includes brdf.glsl and layers.glsl first and may define
// MATERIALS_DIFFUSE.
//
// A point or spot light of intensity I (W/sr) at p gives x the irradiance I cos_s / |p - x|^2
// along l = (p - x) / |p - x|; a spot multiplies it by glTF's cone factor, the square of
// clamp((cos_theta - cos_outer) / (cos_inner - cos_outer), 0, 1) with theta the angle from its
// axis (written as clamp(cos_theta * cone.x + cone.y)^2, cone = (1, -cos_outer) / (cos_inner -
// cos_outer); (0, 1) for a point light). A directional light (kind 2) gives E cos_s from l = -d.
// The radiance towards v is the BRDF times that: exact, no sampling.

#ifndef COMPARE_PUNCTUAL_LIGHT_GLSL
#define COMPARE_PUNCTUAL_LIGHT_GLSL

// The direction l from x to the light and the light's irradiance on a plane facing it.
void punctual_incidence(vec3 x, float kind, vec3 position, vec3 direction, vec2 cone, out vec3 l,
                        out float irradiance) {
    if (kind > 1.5) {
        l = -direction;
        irradiance = 1.0;
        return;
    }
    vec3 to_p = position - x;
    float d2 = max(dot(to_p, to_p), 1e-12);
    l = to_p * inversesqrt(d2);
    float t = clamp(dot(-l, direction) * cone.x + cone.y, 0.0, 1.0);
    irradiance = t * t / d2;
}

vec3 punctual_radiance(vec3 x, vec3 n, vec3 v, vec3 base, float metallic, float roughness, float kind,
                       vec3 position, vec3 direction, vec3 intensity, vec2 cone) {
    vec3 l;
    float e;
    punctual_incidence(x, kind, position, direction, cone, l, e);
    float cos_s = dot(n, l);
    if (cos_s <= 0.0 || dot(n, v) <= 0.0 || e <= 0.0) {
        return vec3(0.0);
    }
#if MATERIALS_DIFFUSE
    return base * (1.0 / BRDF_PI) * intensity * (e * cos_s);
#else
    vec3 spec;
    vec3 diff;
    material_lobes(n, v, l, base, metallic, roughness, spec, diff);
    return (spec + diff) * intensity * (e * cos_s);
#endif
}

#endif // COMPARE_PUNCTUAL_LIGHT_GLSL
