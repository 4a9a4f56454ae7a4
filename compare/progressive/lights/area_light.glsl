// The direct light of one rectangular area light through one sample point: the math
// shared by the direct-light pass (direct.glsl, with shadows) and the forward-shaded
// first frame (first_frame.glsl, unshadowed, from each light's centre).
//
// The includer declares the light as u_light_center, u_light_t, u_light_b, u_light_n,
// u_light_half, u_light_radiance, u_light_area (uniforms, or globals it sets per
// light), includes brdf.glsl and layers.glsl first, and may define AREA_MODEL_PAPER, AREA_MODEL_LTC
// (then it includes ltc.glsl after this file) and MATERIALS_DIFFUSE (see direct.glsl).

#ifndef COMPARE_AREA_LIGHT_GLSL
#define COMPARE_AREA_LIGHT_GLSL

// Solid angle of the triangle (a, b, c) seen from the origin (Van Oosterom & Strackee 1983).
float triangle_solid_angle(vec3 a, vec3 b, vec3 c) {
    float la = length(a);
    float lb = length(b);
    float lc = length(c);
    float num = abs(dot(a, cross(b, c)));
    float den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    return 2.0 * atan(num, den);
}

// Solid angle of the light's rectangle seen from x.
float light_solid_angle(vec3 x) {
    vec3 c = u_light_center - x;
    vec3 du = u_light_t * u_light_half.x;
    vec3 dv = u_light_b * u_light_half.y;
    vec3 p0 = c - du - dv;
    vec3 p1 = c + du - dv;
    vec3 p2 = c + du + dv;
    vec3 p3 = c - du + dv;
    return triangle_solid_angle(p0, p1, p2) + triangle_solid_angle(p0, p2, p3);
}

// Karis' most representative point: the point of the rectangle closest to the ray
// x + t r, taken as the ray's hit on the light's plane clamped to the rectangle
// (exact where the ray hits the rectangle); a ray parallel to or leaving the plane
// heads for the rectangle's edge in the ray's direction.
vec3 representative_point(vec3 x, vec3 r) {
    float denom = dot(r, u_light_n);
    vec3 h;
    if (denom < -1e-6) {
        h = x + r * max(dot(u_light_center - x, u_light_n) / denom, 0.0);
    } else {
        vec3 along = r - u_light_n * denom;
        h = x + along * (1e4 * (distance(x, u_light_center) + u_light_half.x + u_light_half.y));
    }
    vec3 q = h - u_light_center;
    vec2 uv = clamp(vec2(dot(q, u_light_t), dot(q, u_light_b)), -u_light_half, u_light_half);
    return u_light_center + uv.x * u_light_t + uv.y * u_light_b;
}

#if !MATERIALS_DIFFUSE
uniform sampler2D u_spec_lut;  // split-sum table (compare/ibl/lut.py): A, B over (n.v, roughness)

// Specular through the representative point, with an energy normalisation in the
// spirit of Karis' sphere lights: the light widens the lobe of half vectors, and
// the GGX peak D = 1 / (pi alpha^2) evaluated at p must not be counted over the
// light's whole solid angle. Karis widens alpha by r / (2 d) (r = sqrt(A / pi), the
// radius of the disc of equal area; d the distance to the light's centre), which is
// the light's half-angle r / d mapped to half vectors at normal incidence. Away
// from it the map from l to h is anisotropic: turning l within the plane of
// incidence turns h by half the angle, but its Jacobian d omega_h / d omega_l is
// 1 / (4 v.h), so across that plane h turns by 1 / (2 v.h) of l's angle. The factor
// is therefore alpha^2 / ((alpha + rho) (alpha + rho / v.h)), rho = r / (2 d): Karis'
// (alpha / alpha')^2 at v.h = 1, and far smaller at grazing views, where the plain
// form reflects many times the light's radiance (scenes/stress/grazing.toml).
// Last, a light can never reflect more than L times the lobe's directional albedo
// F0 A + B (the split-sum table), whatever part of the hemisphere it covers.
//
// specular_normalised applies both to spec (the specular lobe towards l) times
// omega_cos (the light's solid angle times the cosine at the surface); d is the
// distance to the light's centre.
// The normalisation of a lobe of the given roughness, and its albedo bound from the table's (A, B).
float specular_k2(vec3 v, vec3 l, float d, float roughness) {
    float alpha = brdf_alpha_from_roughness(roughness);
    float rho = sqrt(u_light_area / BRDF_PI) / (2.0 * d);
    float vh = clamp(dot(v, normalize(v + l)), 1e-3, 1.0);
    return alpha * alpha / (min(alpha + rho, 1.0) * min(alpha + rho / vh, 1.0));
}

vec2 specular_ab(vec3 n, vec3 v, float roughness) {
    return textureLod(u_spec_lut, vec2(dot(n, v), clamp(roughness, 0.0, 1.0)), 0.0).rg;
}

vec3 specular_normalised(vec3 spec, float omega_cos, vec3 n, vec3 v, vec3 l, float d, vec3 base, float metallic,
                         float roughness) {
    vec2 ab = specular_ab(n, v, roughness);
#if LAYERS
    vec3 albedo;
    float unused;
    layers_base_weights(base, metallic, vec3(ab, 1.0 - BRDF_DIELECTRIC_F0), albedo, unused);
#else
    vec3 f0 = vec3(BRDF_DIELECTRIC_F0) + (base - vec3(BRDF_DIELECTRIC_F0)) * clamp(metallic, 0.0, 1.0);
    vec3 albedo = f0 * ab.x + ab.y;
#endif
    return min(spec * (omega_cos * specular_k2(v, l, d, roughness)), albedo) * u_light_radiance;
}

#if LAYERS
// The coat's lobe through the representative point, normalised for its own roughness and bounded by
// its own albedo (what specular_normalised does for the base's).
vec3 coat_normalised(float coat, float omega_cos, vec3 n, vec3 v, vec3 l, float d) {
    float bound = coat_albedo(specular_ab(n, v, g_layers.clearcoat_roughness));
    return vec3(min(coat * omega_cos * specular_k2(v, l, d, g_layers.clearcoat_roughness), bound)) * u_light_radiance;
}
#endif

vec3 specular_mrp(vec3 x, vec3 n, vec3 v, vec3 base, float metallic, float roughness) {
    vec3 p = representative_point(x, reflect(-v, n));
    vec3 to_p = p - x;
    float dp2 = max(dot(to_p, to_p), 1e-12);
    vec3 l = to_p * inversesqrt(dp2);
    float cos_p = dot(n, l);
    vec3 spec;
    vec3 diff;
    float coat;
    if (cos_p <= 0.0 || !material_lobes_split(n, v, l, base, metallic, roughness, spec, diff, coat)) {
        return vec3(0.0);
    }
#if AREA_MODEL_PAPER
    float omega = u_light_area / (4.0 * dp2);  // Phi / (4 pi d^2) / L with Phi = pi A L
#else
    float omega = light_solid_angle(x);
#endif
    vec3 out_spec = specular_normalised(spec, omega * cos_p, n, v, l, distance(x, u_light_center), base, metallic,
                                        roughness);
#if LAYERS
    out_spec += coat_normalised(coat, omega * cos_p, n, v, l, distance(x, u_light_center));
#endif
    return out_spec;
}
#endif

// The solid angle that a sample point standing for the light's area A subtends at squared
// distance d2 (cos_l: the emitter's cosine towards x): A cos_l / d2, or with AREA_MODEL_PAPER
// the paper's isotropic point light, Phi / (4 pi d2) / L = A / (4 d2).
float point_solid_angle(float d2, float cos_l) {
#if AREA_MODEL_PAPER
    return u_light_area / (4.0 * d2);
#else
    return u_light_area * cos_l / d2;
#endif
}

// Whether the light can reach the viewer through x at all: x in front of the one-sided
// emitter, and the one-sided BRDF seen from its front (n.v > 0).
bool light_reaches(vec3 x, vec3 n, vec3 v) {
    return dot(x - u_light_center, u_light_n) > 0.0 && dot(n, v) > 0.0;
}

// Direction l from x to the light point y, squared distance d2, and the cosines at the
// surface (n.l) and at the emitter (-n_l.l).
void sample_direction(vec3 x, vec3 n, vec3 y, out vec3 l, out float d2, out float cos_s, out float cos_l) {
    vec3 to_y = y - x;
    d2 = max(dot(to_y, to_y), 1e-12);
    l = to_y * inversesqrt(d2);
    cos_s = dot(n, l);
    cos_l = -dot(u_light_n, l);
}

// The unshadowed single-sample estimate of the light's direct light at x (normal n,
// towards the viewer v) through the sample point y: diffuse through y, specular
// through the representative point (see the notes at the top of direct.glsl).
vec3 light_estimate(vec3 x, vec3 n, vec3 v, vec3 y, vec3 base, float metallic, float roughness) {
    if (!light_reaches(x, n, v)) {
        return vec3(0.0);
    }
    vec3 l;
    float d2;
    float cos_s;
    float cos_l;
    sample_direction(x, n, y, l, d2, cos_s, cos_l);

    vec3 diffuse = vec3(0.0);
    if (cos_s > 0.0 && cos_l > 0.0) {
        vec3 diff_lobe;
#if MATERIALS_DIFFUSE
        diff_lobe = base * (1.0 / BRDF_PI);
#else
        vec3 spec_lobe;
        material_lobes(n, v, l, base, metallic, roughness, spec_lobe, diff_lobe);
#endif
        diffuse = diff_lobe * u_light_radiance * (point_solid_angle(d2, cos_l) * cos_s);
    }
    vec3 specular = vec3(0.0);
#if !MATERIALS_DIFFUSE
    specular = specular_mrp(x, n, v, base, metallic, roughness);
#endif
    return diffuse + specular;
}

#if AREA_MODEL_LTC
void ltc_light(vec3 x, vec3 n, vec3 v, vec3 base, float metallic, float roughness, out vec3 diffuse,
               out vec3 specular);
#endif

// A cheaper unshadowed estimate for the first frame's preview: the whole light
// placed at its centre (one BRDF evaluation, both lobes towards the centre, solid
// angle A cos_l / d^2), with the specular normalisation and albedo bound of
// specular_mrp. Far cheaper than light_estimate (no spherical triangles, no
// representative point); glossy highlights sit where the centre reflects.
// With AREA_MODEL_LTC the preview is the closed-form unshadowed light (ltc.glsl) instead.
vec3 light_preview(vec3 x, vec3 n, vec3 v, vec3 base, float metallic, float roughness) {
#if AREA_MODEL_LTC
    vec3 ltc_diffuse;
    vec3 ltc_specular;
    ltc_light(x, n, v, base, metallic, roughness, ltc_diffuse, ltc_specular);
    return ltc_diffuse + ltc_specular;
#endif
    vec3 to_c = u_light_center - x;
    float d2 = max(dot(to_c, to_c), 1e-12);
    vec3 l = to_c * inversesqrt(d2);
    float cos_s = dot(n, l);
    float cos_l = -dot(u_light_n, l);
    if (cos_s <= 0.0 || cos_l <= 0.0 || dot(n, v) <= 0.0) {
        return vec3(0.0);
    }
    float omega = point_solid_angle(d2, cos_l);
#if MATERIALS_DIFFUSE
    return base * (1.0 / BRDF_PI) * u_light_radiance * (omega * cos_s);
#else
    vec3 spec;
    vec3 diff;
    material_lobes(n, v, l, base, metallic, roughness, spec, diff);
    return diff * (omega * cos_s) * u_light_radiance
           + specular_normalised(spec, omega * cos_s, n, v, l, sqrt(d2), base, metallic, roughness);
#endif
}

#endif // COMPARE_AREA_LIGHT_GLSL
