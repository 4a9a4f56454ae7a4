// Irradiance volume lookup: E_indirect(x, n) from a regular grid of SH9 probes
// (compare/progressive/indirect/probes.py bakes the grid and documents the method).
//
//   E(x, n) = sum_p w_p E_p(n) / sum_p w_p        over the 8 probes of x's grid cell
//   E_p(n)  = max(0, sum_k c_pk Y_k(n))          c_pk already multiplied by A_l (Ramamoorthi & Hanrahan)
//   w_p     = trilinear * backface * chebyshev   (invalid probes: 0), DDGI (Majercik et al. 2019)
//
// Textures (probe p sits in tile (p % u_probe_tiles, p / u_probe_tiles)):
//   u_probe_sh        RGBA32F, 9 texels per tile: coefficient k of probe p at (9 tile.x + k, tile.y);
//                     alpha of coefficient 0 is 1 for a valid probe, 0 for one inside geometry
//   u_probe_distance  RG32F octahedral maps with a 1-texel border ((D + 2)^2 per tile): mean distance
//                     and mean squared distance to the nearest surface, filtered by a cosine lobe
//
// Define PROBE_LEAK_LIMIT 0 for the plain trilinear mean (an ablation: no backface, visibility
// or validity weights). Needs mapping.glsl (env_octahedral_encode) included first. One level of
// includes only.

#ifndef COMPARE_PROBES_GLSL
#define COMPARE_PROBES_GLSL

uniform sampler2D u_probe_sh;
uniform sampler2D u_probe_distance;
uniform ivec3 u_probe_counts;        // probes along x, y, z (each >= 2)
uniform vec3 u_probe_origin;         // position of probe (0, 0, 0)
uniform vec3 u_probe_spacing;        // distance between neighbouring probes along x, y, z
uniform int u_probe_tiles;           // tiles per row of both textures
uniform float u_probe_distance_size; // interior size D of one octahedral distance map
uniform vec2 u_probe_distance_atlas; // size of u_probe_distance in texels
uniform float u_probe_bias;          // surface bias length (world units)

// The 9 real SH basis functions (compare/ibl/irradiance.py's order and constants).
void probe_sh_basis(vec3 n, out float y[9]) {
    y[0] = 0.282095;
    y[1] = 0.488603 * n.y;
    y[2] = 0.488603 * n.z;
    y[3] = 0.488603 * n.x;
    y[4] = 1.092548 * n.x * n.y;
    y[5] = 1.092548 * n.y * n.z;
    y[6] = 0.315392 * (3.0 * n.z * n.z - 1.0);
    y[7] = 1.092548 * n.x * n.z;
    y[8] = 0.546274 * (n.x * n.x - n.y * n.y);
}

ivec2 probe_tile(int p) {
    return ivec2(p % u_probe_tiles, p / u_probe_tiles);
}

// Mean and mean squared distance from probe p towards the unit direction d (bilinear, seamless
// through the border).
vec2 probe_moments(int p, vec3 d) {
    vec2 origin = vec2(probe_tile(p)) * (u_probe_distance_size + 2.0);
    vec2 px = origin + 1.0 + env_octahedral_encode(d) * u_probe_distance_size;
    return textureLod(u_probe_distance, px / u_probe_distance_atlas, 0.0).rg;
}

// Indirect irradiance at x with unit normal n, seen from the unit direction v (towards the
// viewer: it moves the lookup point off the surface, away from the surface's back side).
// All 8 probes are evaluated in one pass (their irradiance also feeds the fall-back), without
// skipping probes of weight zero: a branch runs for the whole SIMD group
// (docs/performance-notes.md).
vec3 probe_irradiance(vec3 x, vec3 n, vec3 v) {
    float y[9];
    probe_sh_basis(n, y);
    // DDGI's surface bias: off the surface along the normal and towards the viewer, so that
    // the Chebyshev test does not see the surface itself as an occluder.
    vec3 xb = x + (0.2 * n + 0.8 * v) * u_probe_bias;
    vec3 g = (xb - u_probe_origin) / u_probe_spacing;
    ivec3 base = clamp(ivec3(floor(g)), ivec3(0), u_probe_counts - 2);
    vec3 a = clamp(g - vec3(base), 0.0, 1.0);
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    vec3 plain = vec3(0.0);  // unweighted trilinear mean, the fall-back
    for (int k = 0; k < 8; ++k) {
        ivec3 o = ivec3(k & 1, (k >> 1) & 1, (k >> 2) & 1);
        ivec3 idx = base + o;
        int p = idx.x + u_probe_counts.x * (idx.y + u_probe_counts.y * idx.z);
        vec3 t = mix(1.0 - a, a, vec3(o));
        float trilinear = t.x * t.y * t.z;
        ivec2 tc = probe_tile(p) * ivec2(9, 1);
        vec4 c0 = texelFetch(u_probe_sh, tc, 0);
        vec3 e = c0.rgb * y[0];
        for (int j = 1; j < 9; ++j) {
            e += texelFetch(u_probe_sh, tc + ivec2(j, 0), 0).rgb * y[j];
        }
        e = max(e, vec3(0.0));  // SH9 rings below zero behind bright sources
        plain += trilinear * e;
#if PROBE_LEAK_LIMIT
        if (c0.a < 0.5) {
            continue;  // inside geometry: its light is that of back faces
        }
        vec3 probe = u_probe_origin + vec3(idx) * u_probe_spacing;
        // Smooth backface weight: probes behind the surface count little, never nothing
        // (the unbiased point, so that the true side of the surface decides).
        vec3 to_probe = probe - x;
        float facing = (dot(to_probe, n) / max(length(to_probe), 1e-12) + 1.0) * 0.5;
        float w = facing * facing + 0.2;
        // Chebyshev visibility: is xb farther from the probe than the probe's surfaces?
        vec3 from_probe = xb - probe;
        float r = length(from_probe);
        vec2 m = probe_moments(p, from_probe / max(r, 1e-12));
        if (r > m.x) {
            float variance = abs(m.y - m.x * m.x);
            float dr = r - m.x;
            float chebyshev = variance / max(variance + dr * dr, 1e-30);
            w *= chebyshev * chebyshev * chebyshev;
        }
        w = max(w, 1e-6);
        // Crush small weights further: a probe seen through a wall keeps a fraction far below 1%.
        const float crush = 0.2;
        if (w < crush) {
            w *= w * w / (crush * crush);
        }
        w *= trilinear;
        sum += w * e;
        wsum += w;
#endif
    }
    return wsum > 0.0 ? sum / wsum : plain;
}

uniform sampler2D u_probe_lut;  // split-sum table (compare/ibl/lut.py): b = C(n.v), the diffuse factor

// Indirect diffuse light reflected towards v: (1 - m) c C(n.v) E_indirect / pi, the environment's
// diffuse convention (ibl.glsl's env_split_sum); Lambert c E / pi with MATERIALS_DIFFUSE.
// Zero when n.v <= 0 (the shared BRDF is one-sided).
vec3 probe_diffuse(vec3 x, vec3 n, vec3 v, vec3 base, float metallic, float roughness) {
    float nv = dot(n, v);
    if (nv <= 0.0) {
        return vec3(0.0);
    }
    vec3 e = probe_irradiance(x, n, v);
#if MATERIALS_DIFFUSE
    return base * e * (1.0 / 3.14159265358979323846);
#else
    float c = textureLod(u_probe_lut, vec2(nv, clamp(roughness, 0.0, 1.0)), 0.0).b;
    return (1.0 - clamp(metallic, 0.0, 1.0)) * base * e * (c / 3.14159265358979323846);
#endif
}

#endif // COMPARE_PROBES_GLSL
