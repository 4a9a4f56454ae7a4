// Direct light of one area-light sample (Otto et al. 2020), full screen over the G-buffer.
//
// For a sample point y on light i (area A, radiance L, normal n_l) and a surface
// point x with normal n, view direction v, this pass computes the single-sample
// estimate
//
//   est = V(x, y) * ( f_d(n, v, l_y) L A cos_s cos_l / |y - x|^2        diffuse through y
//                   + f_s(n, v, l_p) L Omega cos_p (alpha / alpha')^2 )  specular through p
//
// and writes weight * est (weight = F / n_i, see distributor.py). Averaged over the
// n_i samples the diffuse term is the point-on-area Monte Carlo estimate of the
// area integral, exact in the limit (radiometric model). The specular term uses
// Karis' most representative point p (the point of the rectangle closest to the
// reflection ray) with the sphere-light energy normalisation; it is the same for
// every sample, so its mean is the MRP specular times the mean visibility.
//
// Defines: SHADOWS (0 for the unshadowed preview), AREA_MODEL_PAPER (the paper's
// isotropic point light Phi / (4 pi d^2) instead of L A cos_l / d^2),
// MATERIALS_DIFFUSE (Lambert f = c / pi only, for closed-form validation).

#if defined VERTEX_SHADER

void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}

#elif defined FRAGMENT_SHADER

#include "brdf.glsl"

uniform sampler2D u_position;  // G-buffer: world position, w = kind
uniform sampler2D u_normal;    // G-buffer: shading normal, w = roughness
uniform sampler2D u_material;  // G-buffer: base colour, a = metallic
uniform sampler2D u_partial;   // this frame's sum of its earlier samples
uniform sampler2D u_previous;  // direct running mean before this frame

uniform vec3 u_camera_position;
uniform vec3 u_light_center;
uniform vec3 u_light_t;        // unit tangent (first side)
uniform vec3 u_light_b;        // unit bitangent (second side), t x b = n
uniform vec3 u_light_n;        // unit normal, the emitting side
uniform vec2 u_light_half;     // half side lengths along t and b
uniform vec3 u_light_radiance;
uniform float u_light_area;
uniform vec3 u_sample;         // the sample point y on the light
uniform float u_weight;        // F / n_i (1 for the preview)
uniform int u_mode;            // 0: output weight * est (blended additively); 1: update the running mean
uniform float u_count;         // mode 1: 1-based index of this light frame
uniform float u_use_partial;   // mode 1: add u_partial (the frame's earlier samples)

#if SHADOWS
uniform sampler2D u_shadow;            // depth atlas: distance from y to the nearest surface / far
uniform float u_shadow_far;            // the far distance of the shadow faces
uniform mat4 u_face_view_proj[5];      // front (+n), +t, -t, +b, -b
uniform vec4 u_face_rect[5];           // tile origin (xy) and size (zw) in texels
uniform float u_shadow_texel;          // size of one texel in tangent units (2 / S)
uniform vec3 u_bias;                   // normal offset, constant and slope-scaled bias, in texels
#endif

out vec4 out_color;

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
// Specular through the representative point, with the energy normalisation
// (alpha / alpha')^2, alpha' = min(alpha + r / (2 d), 1), where r = sqrt(A / pi) is the
// radius of the disc of the light's area and d the distance to its centre: the light
// subtends a half-angle of about r / d, which widens the lobe of half vectors by
// r / (2 d); without it a smooth surface would see the lobe's peak D = 1 / (pi alpha^2)
// over the whole solid angle and reflect far more than L.
vec3 specular_mrp(vec3 x, vec3 n, vec3 v, vec3 base, float metallic, float roughness) {
    vec3 p = representative_point(x, reflect(-v, n));
    vec3 to_p = p - x;
    float dp2 = max(dot(to_p, to_p), 1e-12);
    vec3 l = to_p * inversesqrt(dp2);
    float cos_p = dot(n, l);
    vec3 spec;
    vec3 diff;
    if (cos_p <= 0.0 || !brdf_eval_lobes(n, v, l, base, metallic, roughness, spec, diff)) {
        return vec3(0.0);
    }
    float alpha = brdf_alpha_from_roughness(roughness);
    float radius = sqrt(u_light_area / BRDF_PI);
    float alpha_wide = min(alpha + radius / (2.0 * distance(x, u_light_center)), 1.0);
    float k = alpha / alpha_wide;
#if AREA_MODEL_PAPER
    float omega = u_light_area / (4.0 * dp2);  // Phi / (4 pi d^2) / L with Phi = pi A L
#else
    float omega = light_solid_angle(x);
#endif
    return spec * u_light_radiance * (omega * cos_p * k * k);
}
#endif

#if SHADOWS
// Visibility of y from x through the five-face shadow atlas.
//
// Bias, all in units of the shadow texel's world size at x's distance (texel = 2 d / S):
// the receiver is moved along its normal (turned towards y) by u_bias.x texels
// (normal offset), then compared with the stored distance plus
// u_bias.y + u_bias.z * tan(theta) texels (constant + slope-scaled; theta is the angle
// between the normal and the direction to y, tan capped at 10).
float visibility(vec3 x, vec3 n) {
    vec3 to_y = u_sample - x;
    float dist = length(to_y);
    float texel = u_shadow_texel * dist;
    float c = dot(n, to_y) / max(dist, 1e-20);
    vec3 n_y = c >= 0.0 ? n : -n;
    c = clamp(abs(c), 1e-3, 1.0);
    float tan_theta = min(sqrt(1.0 - c * c) / c, 10.0);
    vec3 xo = x + n_y * (u_bias.x * texel);
    vec3 d = xo - u_sample;
    vec3 q = vec3(dot(d, u_light_t), dot(d, u_light_b), dot(d, u_light_n));
    int face;
    if (q.z >= abs(q.x) && q.z >= abs(q.y)) {
        face = 0;
    } else if (abs(q.x) >= abs(q.y)) {
        face = q.x > 0.0 ? 1 : 2;
    } else {
        face = q.y > 0.0 ? 3 : 4;
    }
    vec4 clip = u_face_view_proj[face] * vec4(xo, 1.0);
    vec2 ndc = clip.xy / max(clip.w, 1e-20);
    vec4 rect = u_face_rect[face];
    vec2 texel_pos = clamp(rect.xy + (ndc * 0.5 + 0.5) * rect.zw, rect.xy, rect.xy + rect.zw - 1.0);
    float stored = texelFetch(u_shadow, ivec2(texel_pos), 0).r * u_shadow_far;
    float bias = texel * (u_bias.y + u_bias.z * tan_theta);
    return length(d) <= stored + bias ? 1.0 : 0.0;
}
#endif

vec3 sample_estimate(vec3 x, vec3 n, vec3 base, float metallic, float roughness) {
    if (dot(x - u_light_center, u_light_n) <= 0.0) {
        return vec3(0.0);  // behind the one-sided emitter
    }
    vec3 v = normalize(u_camera_position - x);
    if (dot(n, v) <= 0.0) {
        return vec3(0.0);  // one-sided BRDF seen from behind
    }
    vec3 to_y = u_sample - x;
    float d2 = max(dot(to_y, to_y), 1e-12);
    vec3 l = to_y * inversesqrt(d2);
    float cos_s = dot(n, l);
    float cos_l = -dot(u_light_n, l);

    vec3 diffuse = vec3(0.0);
    if (cos_s > 0.0 && cos_l > 0.0) {
        vec3 diff_lobe;
#if MATERIALS_DIFFUSE
        diff_lobe = base * (1.0 / BRDF_PI);
#else
        vec3 spec_lobe;
        brdf_eval_lobes(n, v, l, base, metallic, roughness, spec_lobe, diff_lobe);
#endif
#if AREA_MODEL_PAPER
        diffuse = diff_lobe * u_light_radiance * (u_light_area * cos_s / (4.0 * d2));
#else
        diffuse = diff_lobe * u_light_radiance * (u_light_area * cos_s * cos_l / d2);
#endif
    }
    vec3 specular = vec3(0.0);
#if !MATERIALS_DIFFUSE
    specular = specular_mrp(x, n, v, base, metallic, roughness);
#endif
    vec3 est = diffuse + specular;
#if SHADOWS
    if (max(est.r, max(est.g, est.b)) > 0.0) {
        est *= visibility(x, n);
    }
#endif
    return est;
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 gp = texelFetch(u_position, p, 0);
    vec3 c = vec3(0.0);
    if (gp.w > 0.5 && gp.w < 1.5) {
        vec4 gn = texelFetch(u_normal, p, 0);
        vec4 gm = texelFetch(u_material, p, 0);
        c = u_weight * sample_estimate(gp.xyz, normalize(gn.xyz), gm.rgb, gm.a, gn.w);
    }
    if (u_mode == 0) {
        out_color = vec4(c, 1.0);
        return;
    }
    if (u_use_partial > 0.5) {
        c += texelFetch(u_partial, p, 0).rgb;
    }
    vec3 a = u_count > 1.0 ? texelFetch(u_previous, p, 0).rgb : vec3(0.0);
    out_color = vec4(a + (c - a) / u_count, 1.0);
}

#endif
