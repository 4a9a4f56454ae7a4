// glTF 2.0 metallic-roughness BRDF: the GLSL form of compare/brdf/__init__.py.
//
// Included by text substitution (compare.brdf.glsl.glsl_source(), which writes the constants
// ahead of it); no #version line, functions and #defines only, GLSL 3.30 core. Every formula
// and clamp mirrors the numpy reference; read its module docstring for the model and the
// references. tests/test_brdf_agreement.py renders this file and compares it.
//
//   f = F D V + (1 - m) (1 - F_d) c / pi       (glTF 2.0 appendix B, expanded)
//
// Vectors n, v, l are unit length and in the same space; v points to the viewer,
// l to the light. The result is not multiplied by n.l.

#ifndef COMPARE_BRDF_GLSL
#define COMPARE_BRDF_GLSL

#define BRDF_PI 3.14159265358979323846
// compare/brdf/__init__.py's constants, written ahead of this file by glsl_source() (BRDF_DEFINES).
#ifndef BRDF_ALPHA_MIN
#error BRDF_ALPHA_MIN comes from compare/brdf/glsl.py (compare.brdf.ALPHA_MIN) as a define
#endif
#ifndef BRDF_COS_MIN
#error BRDF_COS_MIN comes from compare/brdf/glsl.py (compare.brdf.COS_MIN) as a define
#endif
#ifndef BRDF_DIELECTRIC_F0
#error BRDF_DIELECTRIC_F0 comes from compare/brdf/glsl.py (compare.brdf.DIELECTRIC_F0) as a define
#endif
#ifndef BRDF_H_LEN2_MIN
#error BRDF_H_LEN2_MIN comes from compare/brdf/glsl.py (compare.brdf.H_LEN2_MIN) as a define
#endif
#ifndef BRDF_DENOM_MIN
#error BRDF_DENOM_MIN comes from compare/brdf/glsl.py (compare.brdf.DENOM_MIN) as a define
#endif

// GGX alpha from perceptual roughness: max(clamp(r, 0, 1)^2, BRDF_ALPHA_MIN).
float brdf_alpha_from_roughness(float roughness) {
    float r = clamp(roughness, 0.0, 1.0);
    return max(r * r, BRDF_ALPHA_MIN);
}

// GGX D in the Lagrange form (alpha / (|n x h|^2 + (n.h alpha)^2))^2 / pi.
float brdf_ggx_d(float n_dot_h, float sin2_theta_h, float alpha) {
    float a = n_dot_h * alpha;
    float k = alpha / max(sin2_theta_h + a * a, BRDF_DENOM_MIN);
    return k * k * (1.0 / BRDF_PI);
}

// Height-correlated Smith visibility V = G2 / (4 n.l n.v), cosines floored at BRDF_COS_MIN.
float brdf_smith_v_height_correlated(float n_dot_v, float n_dot_l, float alpha) {
    float nv = max(n_dot_v, BRDF_COS_MIN);
    float nl = max(n_dot_l, BRDF_COS_MIN);
    float a2 = alpha * alpha;
    float gv = nl * sqrt(nv * nv * (1.0 - a2) + a2);
    float gl = nv * sqrt(nl * nl * (1.0 - a2) + a2);
    return 0.5 / (gv + gl);
}

// Schlick's Fresnel, (1 - v.h)^5 as x^2 x^2 x with v.h clamped to [0, 1].
float brdf_schlick_weight(float v_dot_h) {
    float x = clamp(1.0 - v_dot_h, 0.0, 1.0);
    float x2 = x * x;
    return x2 * x2 * x;
}

vec3 brdf_fresnel_schlick(vec3 f0, float v_dot_h) {
    return f0 + (vec3(1.0) - f0) * brdf_schlick_weight(v_dot_h);
}

float brdf_fresnel_schlick(float f0, float v_dot_h) {
    return f0 + (1.0 - f0) * brdf_schlick_weight(v_dot_h);
}

// The cosines of a pair of directions and their half vector h: n.v, n.l, n.h and v.h (the last two
// clamped to [0, 1]) and |n x h|^2 (exact where 1 - (n.h)^2 cancels); false below either horizon or
// for opposite v and l. Shared by every lobe evaluated from them (layers.glsl too).
bool brdf_geometry(vec3 n, vec3 v, vec3 l, out float nv, out float nl, out float nh, out float vh,
                   out float sin2) {
    nv = dot(n, v);
    nl = dot(n, l);
    nh = 0.0;
    vh = 0.0;
    sin2 = 0.0;
    vec3 hu = v + l;
    float len2 = dot(hu, hu);
    if (!(nv > 0.0 && nl > 0.0 && len2 > BRDF_H_LEN2_MIN)) {
        return false;
    }
    vec3 h = hu * inversesqrt(len2);
    nh = clamp(dot(n, h), 0.0, 1.0);
    vh = clamp(dot(v, h), 0.0, 1.0);
    vec3 nxh = cross(n, h);
    sin2 = dot(nxh, nxh);
    return true;
}

// The specular (F D V) and diffuse ((1 - m)(1 - F_d) c / pi) terms; false below the horizon.
bool brdf_eval_lobes(vec3 n, vec3 v, vec3 l, vec3 base_color, float metallic, float roughness,
                     out vec3 specular, out vec3 diffuse) {
    specular = vec3(0.0);
    diffuse = vec3(0.0);
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
    float d = brdf_ggx_d(nh, sin2, alpha);
    float vis = brdf_smith_v_height_correlated(nv, nl, alpha);
    vec3 f0 = vec3(BRDF_DIELECTRIC_F0) + (base_color - vec3(BRDF_DIELECTRIC_F0)) * m;
    vec3 f = brdf_fresnel_schlick(f0, vh);
    float fd = brdf_fresnel_schlick(BRDF_DIELECTRIC_F0, vh);
    specular = f * (d * vis);
    diffuse = ((1.0 - m) * (1.0 - fd)) * base_color * (1.0 / BRDF_PI);
    return true;
}

// f(n, v, l) in sr^-1, not multiplied by n.l; zero below either horizon.
vec3 brdf_eval(vec3 n, vec3 v, vec3 l, vec3 base_color, float metallic, float roughness) {
    vec3 specular;
    vec3 diffuse;
    brdf_eval_lobes(n, v, l, base_color, metallic, roughness, specular, diffuse);
    return specular + diffuse;
}

// GGX visible normal in the local frame (z = normal), spherical caps
// (Dupuy & Benyoub 2023). wi.z > 0, u in [0, 1)^2. Reflect wi about the result
// to get a specular sample direction.
vec3 brdf_sample_ggx_vndf(vec3 wi, float alpha, vec2 u) {
    vec3 ws = normalize(vec3(wi.xy * alpha, wi.z));
    float phi = 2.0 * BRDF_PI * u.x;
    float z = (1.0 - u.y) * (1.0 + ws.z) - ws.z;
    float sin_theta = sqrt(clamp(1.0 - z * z, 0.0, 1.0));
    vec3 c = vec3(sin_theta * cos(phi), sin_theta * sin(phi), z);
    vec3 hs = c + ws;
    vec3 h = vec3(hs.xy * alpha, hs.z);
    return h * inversesqrt(max(dot(h, h), BRDF_DENOM_MIN));
}

#endif // COMPARE_BRDF_GLSL
