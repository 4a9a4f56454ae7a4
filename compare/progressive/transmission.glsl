// glTF's transmission (KHR_materials_transmission, _ior, _volume) for first_frame.glsl: the light a glass
// surface lets through towards the viewer, for the glass pass (GLASS, glass.py) and frame 0 (TRANSMISSION).
//
// glTF's dielectric: specular + (1 - w max F) mix(diffuse, tint btdf, transmission), F the shared BRDF's
// Schlick Fresnel of the file's ior and specular (layers.glsl's g_layers, else BRDF_DIELECTRIC_F0 of ior 1.5);
// first_frame.glsl shades the specular and (1 - transmission) of the diffuse, this file the rest:
//
//   solid (thickness > 0): the view ray refracts through a microfacet normal m (GGX, sampled from the
//   visible normals with this frame's random numbers: the running mean converges to the rough lobe), travels
//   to the exit (the nearest back face of the glass along it, glass.py's back-face target, else thickness x
//   the mesh's scale along it) and refracts out through a microfacet of the exit normal (the back face's,
//   else the slab's -n). Weight (1 - w max F_in) tint (1 - w max F_out) tint exp(-sigma s): the reference
//   tints at each interface, and absorbs by Beer-Lambert over the path s inside (attenuationColor^(s / d)).
//   What it sees: the opaque image where the ray meets the opaque scene (one step along it to the depth
//   behind the exit point), the environment map where nothing is behind or the ray leaves the screen.
//   Light reflected inside (total internal reflection too) is left out.
//   thin wall (thickness 0): the reference's thin dielectric, two interfaces and their inter-reflections,
//   smooth: (1 - F) / (1 + F) tint straight through (the opaque image at the pixel), and the extra
//   reflection F (1 - F) / (1 + F) of the mirror direction; where the glass's back face lies behind (a closed
//   thin-walled mesh), that second wall's share and tint too (glass_second_wall).
//
// Frame 0 drawn forward has no G-buffer (GBUFFER_READ false): a solid's refracted ray sees the environment
// map. A reduced frame 0 (TRANSMISSION without GLASS) has no screen textures at all: the exit is the
// thickness's slab, and the refracted ray sees the environment map (nothing without one).

#ifndef COMPARE_TRANSMISSION_GLSL
#define COMPARE_TRANSMISSION_GLSL

uniform float u_transmission;   // glTF's transmission factor (0: no glass)
uniform vec3 u_glass_iors;      // the ior of each colour channel (KHR_materials_dispersion; equal without it)
uniform float u_thickness;      // KHR_materials_volume's thickness factor, the mesh's own units; 0: thin wall
uniform vec3 u_glass_scale;     // the mesh's scale along each world axis
uniform vec3 u_attenuation;     // Beer-Lambert coefficient per unit of world length (0: no absorption)

#if GLASS
uniform sampler2D u_opaque;         // the opaque scene's displayed image of this frame (bilinear)
uniform sampler2D u_glass_back;     // the nearest back face of the glass: outward normal, plane offset
uniform sampler2D u_glass_share;    // and its glass share, (1 - metallic) x transmission (glass_back.glsl)
uniform float u_glass_seed;         // this frame's index: new microfacet normals every frame
uniform mat4 u_view_proj;           // this frame's (the vertex stage's)
#endif

// The base layer's share at cos_theta: 1 - w max F, F the shared BRDF's Schlick Fresnel (layers.glsl).
float glass_base_share(float cos_theta) {
#if LAYERS
    return 1.0 - g_layers.weight * layers_max3(brdf_fresnel_schlick(g_layers.f0, cos_theta));
#else
    return 1.0 - brdf_fresnel_schlick(BRDF_DIELECTRIC_F0, cos_theta);
#endif
}

#if GLASS
// Four uniform numbers of this pixel and frame (PCG, Jarzynski & Olano 2020).
uvec4 glass_pcg4d(uvec4 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.w; v.y += v.z * v.x; v.z += v.x * v.y; v.w += v.y * v.z;
    v ^= v >> 16u;
    v.x += v.y * v.w; v.y += v.z * v.x; v.z += v.x * v.y; v.w += v.y * v.z;
    return v;
}
vec4 glass_random() {
    uvec4 h = glass_pcg4d(uvec4(uvec2(gl_FragCoord.xy), uint(u_glass_seed), 0x9e37u));
    return vec4(h >> 8u) * (1.0 / 16777216.0);
}

// Where world point x falls on the screen (texture coordinates), and whether it does.
bool glass_project(vec3 x, out vec2 uv) {
    vec4 c = u_view_proj * vec4(x, 1.0);
    uv = c.xy / c.w * 0.5 + 0.5;
    return c.w > 0.0 && all(greaterThanEqual(uv, vec2(0.0))) && all(lessThan(uv, vec2(1.0)));
}

vec4 glass_fetch(sampler2D s, vec2 uv) {
    return texelFetch(s, ivec2(uv * vec2(textureSize(s, 0))), 0);
}
#endif

// A microfacet normal about n seen from w (the visible normals of GGX at roughness), from two uniform numbers.
vec3 glass_microfacet(vec3 n, vec3 w, float roughness, vec2 u) {
    if (roughness <= 0.0) {
        return n;
    }
    vec3 t = normalize(abs(n.z) < 0.999 ? cross(vec3(0.0, 0.0, 1.0), n) : cross(vec3(1.0, 0.0, 0.0), n));
    vec3 b = cross(n, t);
    vec3 local = vec3(dot(w, t), dot(w, b), max(dot(w, n), 1e-4));
    vec3 h = brdf_sample_ggx_vndf(normalize(local), brdf_alpha_from_roughness(roughness), u);
    return normalize(t * h.x + b * h.y + n * h.z);
}

// What the ray from x along d sees.
vec3 glass_behind(vec3 x, vec3 d) {
#if GLASS
    vec2 uv;
    if (GBUFFER_READ && glass_project(x, uv)) {
        vec4 g = glass_fetch(u_gbuffer_position, uv);
        if (g.w > 0.5) {
            // one step along the ray, as far as the opaque surface behind the exit point
            vec3 y = x + d * distance(g.xyz, x);
            if (glass_project(y, uv) && glass_fetch(u_gbuffer_position, uv).w > 0.5) {
                return textureLod(u_opaque, uv, 0.0).rgb;
            }
        }
    }
#endif
#if ENVIRONMENT
    return env_background(d);
#else
    return vec3(0.0);
#endif
}

#if GLASS
// What a thin wall at p (reflectance f at its own interface) lets through of the opaque image when the glass's
// nearest back face lies behind it along -v: a closed thin-walled mesh (a sphere, a box) is two walls, and the
// reference tints at both and passes the light between them. The back face is taken to be of the same material
// (its tint and Fresnel), its glass share its own (glass_back.glsl: where it is opaque, a map's stripe or metal,
// its inner side is left out, dark); its reflection towards the inside is left out. 1 without one.
vec3 glass_second_wall(vec3 p, vec3 v, vec3 tint, float f) {
    vec4 back = texelFetch(u_glass_back, ivec2(gl_FragCoord.xy), 0);
    float tb = dot(back.xyz, -v);
    if (dot(back.xyz, back.xyz) < 0.5 || tb <= 1e-3 || (back.w - dot(back.xyz, p)) / tb <= 1e-4 * (1.0 + length(p))) {
        return vec3(1.0);  // no back face, or this very surface seen from behind
    }
    float t_back = glass_base_share(tb);
    float f_back = 1.0 - t_back;
    // each wall reflects 2F / (1 + F) of the light between them (a thin dielectric's two interfaces)
    float between = 1.0 - (2.0 * f / (1.0 + f)) * (2.0 * f_back / (1.0 + f_back));
    return texelFetch(u_glass_share, ivec2(gl_FragCoord.xy), 0).r * tint * (t_back / (1.0 + f_back)) / between;
}
#endif

// The transmitted radiance towards v of a glass fragment at p (shading normal n facing v), before the
// transmission factor (a thin wall's with its extra reflection).
vec3 glass_transmitted(vec3 p, vec3 n, vec3 v, vec3 tint, float roughness) {
#if GLASS
    vec4 u = glass_random();
#else
    vec4 u = vec4(0.5);
#endif
    if (u_thickness <= 0.0) {
        // thin wall: smooth, straight through (the opaque image at this pixel; the map without screen textures)
        float t_share = glass_base_share(max(dot(n, v), 0.0));
        float f = 1.0 - t_share;
        vec3 through;
#if GLASS
        through = textureLod(u_opaque, gl_FragCoord.xy / vec2(textureSize(u_opaque, 0)), 0.0).rgb;
        through *= glass_second_wall(p, v, tint, f);
#else
        through = glass_behind(p, -v);
#endif
        vec3 extra = vec3(0.0);
#if ENVIRONMENT
        extra = f * env_background(reflect(-v, n));
#endif
        return (t_share / (1.0 + f)) * (tint * through + extra);
    }
    // dispersion: each pixel and frame refracts one colour channel's ior, picked at random, its light times 3
    // in that channel alone (the reference's hero channel: the running mean converges to each channel's
    // refraction); frame 0 and a material without dispersion refract the green channel's, the file's ior
    float ior = u_glass_iors.y;
    vec3 channel = vec3(1.0);
#if GLASS
    if (u_glass_iors.x != u_glass_iors.z) {
        int k = int(glass_pcg4d(uvec4(uvec2(gl_FragCoord.xy), uint(u_glass_seed), 0x51edu)).x % 3u);
        ior = u_glass_iors[k];
        channel = vec3(0.0);
        channel[k] = 3.0;
    }
#endif
    vec3 m = glass_microfacet(n, v, roughness, u.xy);
    float vm = dot(v, m);
    vec3 t = refract(-v, m, 1.0 / ior);
    if (vm <= 0.0 || dot(t, t) == 0.0) {
        return vec3(0.0);
    }
    float weight = glass_base_share(vm);
    // the exit: thickness x the mesh's scale along the ray, or the glass's back face along it
    float s = u_thickness * length(u_glass_scale * t);
    vec3 n_out = -n;
    float exit_share = 1.0;
#if GLASS
    vec2 uv;
    if (glass_project(p + t * s, uv)) {
        vec4 back = glass_fetch(u_glass_back, uv);
        float tb = dot(back.xyz, t);
        if (dot(back.xyz, back.xyz) > 0.5 && tb > 1e-3) {
            float s_back = (back.w - dot(back.xyz, p)) / tb;
            if (s_back > 0.0) {
                s = s_back;
                n_out = back.xyz;
                exit_share = glass_fetch(u_glass_share, uv).r;  // an opaque part of the exit passes nothing
                if (glass_project(p + t * s, uv)) {  // the normal where the ray leaves
                    back = glass_fetch(u_glass_back, uv);
                    n_out = dot(back.xyz, back.xyz) > 0.5 && dot(back.xyz, t) > 1e-3 ? back.xyz : n_out;
                }
            }
        }
    }
#endif
    vec3 m_out = glass_microfacet(-n_out, -t, roughness, u.zw);
    vec3 o = refract(t, m_out, ior);
    if (dot(o, o) == 0.0) {
        return vec3(0.0);  // total internal reflection: left out
    }
    weight *= glass_base_share(max(dot(o, -m_out), 0.0));
    vec3 absorbed = exp(-u_attenuation * s);
    return exit_share * channel * weight * tint * tint * absorbed * glass_behind(p + t * s, o);
}

#endif // COMPARE_TRANSMISSION_GLSL
