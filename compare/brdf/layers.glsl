// glTF's material layers over the core BRDF: the GLSL form of compare/brdf/coat.py, sheen.py and
// dielectric_specular (compare/brdf/__init__.py), for the rasterizer's passes.
//
// Included after brdf.glsl (and after ibl.glsl where a pass lights with the environment), always with
// LAYERS defined 0 or 1. With LAYERS 0 it adds nothing and material_lobes is brdf_eval_lobes, so a
// scene without the extensions runs the code it always ran. With LAYERS 1:
//
//   base     (1 - m) [w F(f0, v.h) D V + (1 - w max F(f0, v.h)) c / pi] + m F(c, v.h) D V   ior, specular
//   sheened  base min(1 - max(s) E(n.v), 1 - max(s) E(n.l)) + s D_charlie V_ashikhmin        sheen
//   coated   sheened (1 - k F_c(v.h)) + k F_c(v.h) D(a_c) V(a_c),  F_c Schlick with F0 0.04     clearcoat
//
// The sheen goes to the diffuse lobe (a broad lobe, lit through the same samples), the coat to the
// specular one. The α floor is the rasterizer's (BRDF_ALPHA_MIN), for the coat as for the base.
//
// The pixel's layers are a file-scope variable, g_layers, set once per fragment by the pass (from
// the G-buffer's layer targets, or the forward pass's material): every lighting function between
// the pass and the BRDF then reads them without each signature carrying them.
//
// Needs u_sheen_albedo: R = E(mu, r) of compare/brdf/sheen.py (albedo_table, rows mu, columns r),
// bilinear, as the reference's plugin reads it; G = M(mu, r) (under_scale_table), the mean of the sheen's
// scale of a Lambertian layer below it over a cosine-weighted hemisphere of light.

#ifndef COMPARE_LAYERS_GLSL
#define COMPARE_LAYERS_GLSL

#ifndef LAYERS
#define LAYERS 0
#endif

#if LAYERS
// compare/brdf/sheen.py's and coat.py's constants, written ahead of this file by layers_source()
// (compare.brdf.glsl.LAYERS_DEFINES).
#ifndef LAYERS_SHEEN_ALPHA_MIN
#error LAYERS_SHEEN_ALPHA_MIN comes from compare/brdf/glsl.py (compare.brdf.sheen.SHEEN_ALPHA_MIN) as a define
#endif
#ifndef LAYERS_SHEEN_TABLE
#error LAYERS_SHEEN_TABLE comes from compare/brdf/glsl.py (compare.brdf.sheen.TABLE_SIZE) as a define
#endif
#ifndef LAYERS_COAT_F0
#error LAYERS_COAT_F0 comes from compare/brdf/glsl.py (compare.brdf.coat.COAT_F0, the coat's IOR 1.5) as a define
#endif

struct MaterialLayers {
    vec3 f0;                    // dielectric F0, min(((ior - 1) / (ior + 1))^2 specular_color, 1)
    float weight;               // specular
    float clearcoat;
    float clearcoat_roughness;
    vec3 sheen_color;
    float sheen_roughness;
};

MaterialLayers g_layers = MaterialLayers(vec3(BRDF_DIELECTRIC_F0), 1.0, 0.0, 0.0, vec3(0.0), 0.0);

uniform sampler2D u_sheen_albedo;

float layers_max3(vec3 c) {
    return max(c.r, max(c.g, c.b));
}

// (E, M)(mu, r): bilinear between the table's grid points (mu, r in [0, 1], grid at
// i / (LAYERS_SHEEN_TABLE - 1)).
vec2 sheen_tables(float mu, float r) {
    vec2 t = (clamp(vec2(r, mu), 0.0, 1.0) * (LAYERS_SHEEN_TABLE - 1.0) + 0.5) / LAYERS_SHEEN_TABLE;
    return textureLod(u_sheen_albedo, t, 0.0).rg;
}

float sheen_albedo(float mu, float r) {
    return sheen_tables(mu, r).x;
}

float sheen_lobe(float nv, float nl, float nh, float roughness) {
    float r = clamp(roughness, 0.0, 1.0);
    float inv = 1.0 / max(r * r, LAYERS_SHEEN_ALPHA_MIN);
    float d = (2.0 + inv) * pow(max(1.0 - nh * nh, 0.0), 0.5 * inv) * (0.5 / BRDF_PI);
    float vis = 1.0 / (4.0 * max(nl + nv - nl * nv, 1e-6));
    return d * vis;
}

// Base (ior, specular), sheen and coat towards l, as brdf_eval_lobes, with the coat's own lobe apart
// (coat; specular and diffuse carry what it lets through): passes that light the coat's sharper lobe
// on its own (a representative point, a shadow ratio) read it there. False below the horizon.
bool brdf_eval_layered_split(vec3 n, vec3 v, vec3 l, vec3 base_color, float metallic, float roughness,
                             MaterialLayers L, out vec3 specular, out vec3 diffuse, out float coat) {
    specular = vec3(0.0);
    diffuse = vec3(0.0);
    coat = 0.0;
    float nv;
    float nl;
    float nh;
    float vh;
    float sin2;
    if (!brdf_geometry(n, v, l, nv, nl, nh, vh, sin2)) {
        return false;
    }

    float m = clamp(metallic, 0.0, 1.0);
    float alpha = brdf_alpha_from_roughness(roughness);
    float dv = brdf_ggx_d(nh, sin2, alpha) * brdf_smith_v_height_correlated(nv, nl, alpha);
    vec3 fr = brdf_fresnel_schlick(L.f0, vh);
    vec3 f = m * brdf_fresnel_schlick(base_color, vh) + (1.0 - m) * L.weight * fr;
    specular = f * dv;
    diffuse = ((1.0 - m) * (1.0 - L.weight * layers_max3(fr))) * base_color * (1.0 / BRDF_PI);

    float peak = layers_max3(L.sheen_color);
    if (peak > 0.0) {
        float scale = min(1.0 - peak * sheen_albedo(nv, L.sheen_roughness),
                          1.0 - peak * sheen_albedo(nl, L.sheen_roughness));
        specular *= scale;
        diffuse = diffuse * scale + L.sheen_color * sheen_lobe(nv, nl, nh, L.sheen_roughness);
    }
    if (L.clearcoat > 0.0) {
        float alpha_c = brdf_alpha_from_roughness(L.clearcoat_roughness);
        float share = L.clearcoat * brdf_fresnel_schlick(LAYERS_COAT_F0, vh);
        coat = share * brdf_ggx_d(nh, sin2, alpha_c) * brdf_smith_v_height_correlated(nv, nl, alpha_c);
        specular *= 1.0 - share;
        diffuse *= 1.0 - share;
    }
    return true;
}

// brdf_eval_layered_split with the coat's lobe in specular.
bool brdf_eval_layered(vec3 n, vec3 v, vec3 l, vec3 base_color, float metallic, float roughness,
                       MaterialLayers L, out vec3 specular, out vec3 diffuse) {
    float coat;
    bool front = brdf_eval_layered_split(n, v, l, base_color, metallic, roughness, L, specular, diffuse, coat);
    specular += vec3(coat);
    return front;
}

// The share of light the coat reflects, seen from n.v (its directional albedo: A + B scaled by the
// coat's Fresnel, from a split-sum table's (A, B) at the coat's roughness): what the layers below
// receive is 1 minus it, in the passes that light a whole lobe at once (environment, LTC).
float coat_albedo(vec2 ab) {
    return g_layers.clearcoat * (LAYERS_COAT_F0 * ab.x + ab.y);
}

// The base's specular scale F0 A + B with ior and specular, and its diffuse weight: the share that
// (1 - w max F) leaves, integrated over the cosine lobe with Schlick's (1 - v.h)^5 as the table's C
// integrates it for F0 = 0.04 (C = 0.96 K, K the integral of 1 - (1 - v.h)^5).
void layers_base_weights(vec3 base, float metallic, vec3 abc, out vec3 spec_scale, out float diffuse_weight) {
    float m = clamp(metallic, 0.0, 1.0);
    spec_scale = m * (base * abc.x + abc.y) + (1.0 - m) * g_layers.weight * (g_layers.f0 * abc.x + abc.y);
    float f0m = layers_max3(g_layers.f0);
    float k = abc.z / (1.0 - BRDF_DIELECTRIC_F0);
    diffuse_weight = (1.0 - m) * max(1.0 - g_layers.weight * (f0m + (1.0 - f0m) * (1.0 - k)), 0.0);
}

#define material_lobes(n, v, l, b, m, r, s, d) brdf_eval_layered(n, v, l, b, m, r, g_layers, s, d)
#define material_lobes_split(n, v, l, b, m, r, s, d, c) brdf_eval_layered_split(n, v, l, b, m, r, g_layers, s, d, c)

#ifdef COMPARE_IBL_GLSL
// env_split_sum with the layers: the base's scale and diffuse weight as above; the sheen lit by the
// irradiance times its albedo E(n.v) (its lobe is broad) and the layers below scaled by 1 - max(s) E;
// the coat a second split sum at its own roughness over everything below.
void env_split_sum_material(vec3 n, vec3 v, vec3 base, float metallic, float roughness,
                            out vec3 diffuse, out vec3 specular) {
    diffuse = vec3(0.0);
    specular = vec3(0.0);
    float nv = dot(n, v);
    if (nv <= 0.0) {
        return;
    }
    vec3 e = u_env_intensity * env_irradiance(normalize(u_env_to_map * n));
    vec3 r = normalize(u_env_to_map * reflect(-v, n));
    vec3 spec_scale;
    float diffuse_weight;
    layers_base_weights(base, metallic, env_lut(nv, roughness), spec_scale, diffuse_weight);
    specular = u_env_intensity * env_prefiltered(r, roughness) * spec_scale;
    diffuse = diffuse_weight * base * e * (1.0 / ENV_PI);
    float peak = layers_max3(g_layers.sheen_color);
    if (peak > 0.0) {
        // The specular lobe below sees the sheen's scale at its mirror direction (n.l = n.v); the diffuse
        // one its cosine-weighted mean.
        vec2 em = sheen_tables(nv, g_layers.sheen_roughness);
        specular *= 1.0 - peak * em.x;
        diffuse = diffuse * (1.0 - peak * em.y) + g_layers.sheen_color * em.x * e * (1.0 / ENV_PI);
    }
    if (g_layers.clearcoat > 0.0) {
        vec3 abc = env_lut(nv, g_layers.clearcoat_roughness);
        float share = coat_albedo(abc.xy);
        specular = specular * (1.0 - share)
                   + u_env_intensity * env_prefiltered(r, g_layers.clearcoat_roughness) * share;
        diffuse *= 1.0 - share;
    }
}
#endif

#else
#define material_lobes(n, v, l, b, m, r, s, d) brdf_eval_lobes(n, v, l, b, m, r, s, d)
#define material_lobes_split(n, v, l, b, m, r, s, d, c) (c = 0.0, brdf_eval_lobes(n, v, l, b, m, r, s, d))
#ifdef COMPARE_IBL_GLSL
#define env_split_sum_material env_split_sum
#endif
#endif // LAYERS

#endif // COMPARE_LAYERS_GLSL
