// Linearly transformed cosines (Heitz, Dupuy, Hill & Neubelt 2016): the unshadowed
// diffuse and GGX specular light of one rectangular light in closed form.
//
// The includer declares the light as area_light.glsl wants it and includes brdf.glsl and
// area_light.glsl (its one-sidedness test, and u_spec_lut, the split-sum table) first.
// Everything here is guarded by AREA_MODEL_LTC, so other area models include it for nothing.
//
// Diffuse: the clamped cosine over the rectangle is Lambert's form factor, exact.
// Specular: the shared BRDF's lobe f_s cos (Fresnel 1) is approximated by a clamped
// cosine transformed by M (compare/brdf/ltc.py fits M^-1 per (roughness, view angle));
// the polygon integral of the transformed cosine is the form factor of the polygon
// transformed by M^-1. Its magnitude is the lobe's directional albedo A + B from the
// split-sum table (the table the environment's split sum uses), its Fresnel Schlick's
// at the mean direction of the lit part of the lobe.

#ifndef COMPARE_LTC_GLSL
#define COMPARE_LTC_GLSL
#if AREA_MODEL_LTC

uniform sampler2D u_ltc;  // LTC_SIZE^2 RGBA32F: M^-1 as (a, b, c, d), x = roughness, y = sqrt(1 - n.v)

#ifndef LTC_SIZE
#error LTC_SIZE comes from direct.py (the LTC table size, compare.brdf.ltc.TABLE_SIZE) as a define
#endif

// M^-1 of the specular lobe, bilinear in the table (texel centres at the grid points).
mat3 ltc_minv(float n_dot_v, float roughness) {
    vec2 uv = vec2(clamp(roughness, 0.0, 1.0), sqrt(clamp(1.0 - n_dot_v, 0.0, 1.0)));
    uv = uv * ((LTC_SIZE - 1.0) / LTC_SIZE) + 0.5 / LTC_SIZE;
    vec4 t = textureLod(u_ltc, uv, 0.0);
    return mat3(vec3(t.x, 0.0, t.y), vec3(0.0, 1.0, 0.0), vec3(t.z, 0.0, t.w));
}

// The edge's share of the vector form factor: acos(v1.v2) * normalize(v1 x v2) / (2 pi),
// for unit v1, v2. theta / (2 pi sin(theta)) is taken from a rational fit (Hill & Heitz
// 2017, also in three.js) instead of acos: in float32 acos loses the angle of short
// edges (a light far away).
vec3 ltc_edge(vec3 v1, vec3 v2) {
    float x = dot(v1, v2);
    float y = abs(x);
    float a = 0.8543985 + (0.4965155 + 0.0145206 * y) * y;
    float b = 3.4175940 + (4.1616724 + y) * y;
    float v = a / b;
    float theta_sintheta = x > 0.0 ? v : 0.5 * inversesqrt(max(1.0 - x * x, 1e-7)) - v;
    return cross(v1, v2) * theta_sintheta;
}

// Clipping a polygon by a plane through the origin: its straight edges are cut where the
// plane cuts their great circles, which is exact. A convex polygon crosses such a plane at
// most twice; the part of the plane between the exit and the entry closes it. The edge
// integrals are additive, so the clipped polygon need not be built, nor its edges taken
// in order: each segment adds its clipped part, and the exit and entry points are kept for
// the closing edge. It is written without branches (selects only): software rasterizers
// run both sides of a branch for every pixel, and GPUs keep their lanes together.

// State of one polygon's clipping to z >= 0, fed one directed segment at a time.
struct LtcClip {
    vec3 f;           // vector form factor of the clipped parts so far
    vec3 exit_point;  // unit direction where the polygon left z >= 0
    vec3 entry_point; // and where it came back
    bool crossed;
};

LtcClip ltc_clip_start() {
    return LtcClip(vec3(0.0), vec3(0.0, 1.0, 0.0), vec3(0.0, 1.0, 0.0), false);
}

// The point of segment a -> b on the plane z = 0 (meaningful where the segment crosses it).
vec3 ltc_crossing(vec3 a, vec3 b) {
    float dz = a.z - b.z;
    vec3 c = mix(a, b, a.z / (abs(dz) > 0.0 ? dz : 1.0));
    return vec3(c.xy, 0.0);
}

// Add the segment a -> b (not necessarily unit) clipped to z >= 0; valid = false adds nothing.
void ltc_clip_segment(inout LtcClip w, vec3 a, vec3 b, bool valid) {
    bool in_a = a.z >= 0.0;
    bool in_b = b.z >= 0.0;
    vec3 c = normalize(ltc_crossing(a, b));
    vec3 s = in_a ? normalize(a) : c;
    vec3 e = in_b ? normalize(b) : c;
    w.f += (valid && (in_a || in_b)) ? ltc_edge(s, e) : vec3(0.0);
    bool exits = valid && in_a && !in_b;
    bool enters = valid && !in_a && in_b;
    w.exit_point = exits ? c : w.exit_point;
    w.entry_point = enters ? c : w.entry_point;
    w.crossed = w.crossed || exits || enters;
}

// The clipped polygon's vector form factor: its z is the form factor, the integral of the
// clamped cosine cos / pi over the polygon's projection on the unit sphere (sign by winding).
vec3 ltc_clip_end(LtcClip w) {
    return w.f + (w.crossed ? ltc_edge(w.exit_point, w.entry_point) : vec3(0.0));
}

// Form factors of the quad q (a frame with z the surface's normal) clipped to the surface's
// horizon: untransformed (diffuse, fd), and transformed by minv and clipped once more to
// the transformed cosine's horizon (specular, fs). The segments of the surface-clipped
// polygon (the quad's clipped edges and the closing one along the horizon) are fed to both.
void ltc_quad_form_factors(vec3 q[4], mat3 minv, out vec3 fd, out vec3 fs) {
    LtcClip wd = ltc_clip_start();
    LtcClip ws = ltc_clip_start();
    vec3 exit_point = vec3(0.0);
    vec3 entry_point = vec3(0.0);
    bool crossed = false;
    for (int i = 0; i < 4; ++i) {
        vec3 a = q[i];
        vec3 b = q[(i + 1) & 3];
        bool in_a = a.z >= 0.0;
        bool in_b = b.z >= 0.0;
        vec3 c = ltc_crossing(a, b);
        vec3 s = in_a ? a : c;
        vec3 e = in_b ? b : c;
        bool valid = in_a || in_b;
        ltc_clip_segment(wd, s, e, valid);
        ltc_clip_segment(ws, minv * s, minv * e, valid);
        exit_point = in_a && !in_b ? c : exit_point;
        entry_point = !in_a && in_b ? c : entry_point;
        crossed = crossed || (in_a != in_b);
    }
    ltc_clip_segment(wd, exit_point, entry_point, crossed);
    ltc_clip_segment(ws, minv * exit_point, minv * entry_point, crossed);
    fd = ltc_clip_end(wd);
    fs = ltc_clip_end(ws);
}

// The frame (t1, t2, n) of a shading point the table is fitted in: t1 is the view
// direction's projection on the tangent plane.
void ltc_frame(vec3 n, vec3 v, out vec3 t1, out vec3 t2) {
    t1 = v - n * dot(n, v);
    float len2 = dot(t1, t1);
    if (len2 < 1e-12) {  // v along n: the lobe is isotropic, any tangent will do
        t1 = abs(n.x) < 0.9 ? cross(n, vec3(1.0, 0.0, 0.0)) : cross(n, vec3(0.0, 1.0, 0.0));
        len2 = dot(t1, t1);
    }
    t1 *= inversesqrt(len2);
    t2 = cross(n, t1);
}

// The light's corners relative to x in the frame of ltc_frame.
void ltc_light_corners(vec3 x, vec3 n, vec3 v, out vec3 q[4]) {
    vec3 t1;
    vec3 t2;
    ltc_frame(n, v, t1, t2);
    vec3 c = u_light_center - x;
    vec3 du = u_light_t * u_light_half.x;
    vec3 dv = u_light_b * u_light_half.y;
    vec3 w[4] = vec3[4](c - du - dv, c + du - dv, c + du + dv, c - du + dv);
    for (int i = 0; i < 4; ++i) {
        q[i] = vec3(dot(w[i], t1), dot(w[i], t2), dot(w[i], n));
    }
}

// The transformed cosine's density (per steradian, integrating to 1) in world direction l at a point
// of normal n seen from v: D_o(M^-1 l / |M^-1 l|) |det M^-1| / |M^-1 l|^3 in the frame of ltc_frame.
float ltc_density(vec3 n, vec3 v, vec3 l, float roughness) {
    vec3 t1;
    vec3 t2;
    ltc_frame(n, v, t1, t2);
    mat3 minv = ltc_minv(dot(n, v), roughness);
    vec3 o = minv * vec3(dot(l, t1), dot(l, t2), dot(l, n));
    float len = length(o);
    if (len <= 0.0 || o.z <= 0.0) {
        return 0.0;
    }
    float det = abs(minv[0][0] * minv[2][2] - minv[2][0] * minv[0][2]);
    return (o.z / len) / 3.14159265358979 * det / (len * len * len);
}

void ltc_light_scaled(vec3 x, vec3 n, vec3 v, vec3 base, float metallic, float roughness, out vec3 diffuse,
                      out vec3 specular, out vec3 spec_scale);

// The unshadowed direct light of the rectangle at x: diffuse and specular parts, each
// in radiance units (times the light's radiance). Zero behind the one-sided emitter and
// for a surface seen from behind.
void ltc_light(vec3 x, vec3 n, vec3 v, vec3 base, float metallic, float roughness, out vec3 diffuse,
               out vec3 specular) {
    vec3 spec_scale;
    ltc_light_scaled(x, n, v, base, metallic, roughness, diffuse, specular, spec_scale);
}

// ltc_light, with the scale the transformed cosine is given (Fresnel times A + B): specular is
// spec_scale |fs.z| u_light_radiance.
void ltc_light_scaled(vec3 x, vec3 n, vec3 v, vec3 base, float metallic, float roughness, out vec3 diffuse,
                      out vec3 specular, out vec3 spec_scale) {
    diffuse = vec3(0.0);
    specular = vec3(0.0);
    spec_scale = vec3(0.0);
    if (!light_reaches(x, n, v)) {
        return;
    }
    float nv = dot(n, v);
    vec3 q[4];
    ltc_light_corners(x, n, v, q);
#if MATERIALS_DIFFUSE
    mat3 minv = mat3(1.0);
#else
    mat3 minv = ltc_minv(nv, roughness);
#endif
    // The specular polygon is clipped to the surface's horizon before the transform too: the
    // transformed cosine of a grazing view has mass below it, where the BRDF has none
    // (tests/test_ltc.py; docs/performance-notes.md).
    vec3 fd;
    vec3 fs;
    ltc_quad_form_factors(q, minv, fd, fs);
    float form_factor = abs(fd.z);
#if MATERIALS_DIFFUSE
    diffuse = base * (form_factor * u_light_radiance);
#else
    // The diffuse lobe's (1 - F_d(v.h)) depends on the light's direction: taken at the
    // direction of the vector form factor (the light's cosine-weighted mean direction),
    // so it is exact for small lights and changes by at most 4 % over the hemisphere.
    float m = clamp(metallic, 0.0, 1.0);
    float len_fd = length(fd);
    vec3 l_mean = len_fd > 0.0 ? sign(fd.z) * fd / len_fd : vec3(0.0, 0.0, 1.0);
    vec3 v_local = vec3(sqrt(max(1.0 - nv * nv, 0.0)), 0.0, nv);
    float vh = clamp(dot(v_local, normalize(v_local + l_mean)), 0.0, 1.0);
#if LAYERS
    float f_d = g_layers.weight * layers_max3(brdf_fresnel_schlick(g_layers.f0, vh));
#else
    float f_d = brdf_fresnel_schlick(BRDF_DIELECTRIC_F0, vh);
#endif
    diffuse = ((1.0 - m) * (1.0 - f_d) * form_factor) * base * u_light_radiance;

    // Magnitude: the lobe's directional albedo with Fresnel 1, A + B of the split-sum table.
    // Fresnel: Schlick's at the half vector of the lit part's mean direction (that of the
    // transformed polygon's vector form factor, mapped back by M), as for the diffuse lobe.
    // The lobe's average F0 A + B would be the Fresnel of the whole hemisphere, too bright at
    // grazing views, where Fresnel changes fastest across the lobe (docs/performance-notes.md).
    vec2 ab = textureLod(u_spec_lut, vec2(nv, clamp(roughness, 0.0, 1.0)), 0.0).rg;
    vec3 f0 = vec3(BRDF_DIELECTRIC_F0) + (base - vec3(BRDF_DIELECTRIC_F0)) * m;
    float len_fs = length(fs);
    vec3 o_mean = len_fs > 0.0 ? sign(fs.z) * fs / len_fs : vec3(0.0, 0.0, 1.0);
    // M = (M^-1)^-1 in closed form for M^-1 = [[a, 0, c], [0, 1, 0], [b, 0, d]] (column-major here).
    float det = minv[0][0] * minv[2][2] - minv[2][0] * minv[0][2];
    vec3 l_spec = normalize(vec3(minv[2][2] * o_mean.x - minv[2][0] * o_mean.z, det * o_mean.y,
                                 -minv[0][2] * o_mean.x + minv[0][0] * o_mean.z) * sign(det));
    float vh_s = clamp(dot(v_local, normalize(v_local + l_spec)), 0.0, 1.0);
#if LAYERS
    f0 = vec3(0.0);  // (the base's Fresnel below, with ior and specular)
    spec_scale = (m * brdf_fresnel_schlick(base, vh_s)
                  + (1.0 - m) * g_layers.weight * brdf_fresnel_schlick(g_layers.f0, vh_s)) * (ab.x + ab.y);
#else
    spec_scale = brdf_fresnel_schlick(f0, vh_s) * (ab.x + ab.y);
#endif
    specular = spec_scale * abs(fs.z) * u_light_radiance;
#if LAYERS
    // The sheen: its albedo E(n.v) times the light's cosine-weighted form factor (a broad lobe), the
    // layers below scaled by 1 - max(s) E. The coat: a second transformed cosine at its roughness, its
    // albedo (layers.glsl's coat_albedo) as scale, over everything below. Both go to the diffuse sum,
    // whose shadow ratio (direct.glsl) is the cosine-weighted visibility: the specular ratio converges
    // to the base's lobe alone.
    float peak = layers_max3(g_layers.sheen_color);
    if (peak > 0.0) {
        vec2 em = sheen_tables(nv, g_layers.sheen_roughness);  // (layers.glsl's env_split_sum_material)
        diffuse = diffuse * (1.0 - peak * em.y) + g_layers.sheen_color * (em.x * form_factor) * u_light_radiance;
        spec_scale *= 1.0 - peak * em.x;
        specular *= 1.0 - peak * em.x;
    }
    if (g_layers.clearcoat > 0.0) {
        vec3 fd_c;
        vec3 fs_c;
        ltc_quad_form_factors(q, ltc_minv(nv, g_layers.clearcoat_roughness), fd_c, fs_c);
        float share = coat_albedo(specular_ab(n, v, g_layers.clearcoat_roughness));
        diffuse = diffuse * (1.0 - share) + share * abs(fs_c.z) * u_light_radiance;
        spec_scale *= 1.0 - share;
        specular *= 1.0 - share;
    }
#endif
#endif
}

#endif // AREA_MODEL_LTC
#endif // COMPARE_LTC_GLSL
