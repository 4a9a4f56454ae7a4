// Which texels of the probes' bake G-buffer (probes_gbuffer.glsl) are lit and reflect: the front side
// (albedo target's w = 1) of a shaded surface (normal target's w = kind 1); misses (0), light quads (2)
// and back faces stay black. One definition for the bake's direct and bounce passes.

#ifndef COMPARE_PROBES_SURFACE_GLSL
#define COMPARE_PROBES_SURFACE_GLSL

bool bake_front_surface(vec4 normal_kind, vec4 albedo_side) {
    return normal_kind.w > 0.5 && normal_kind.w < 1.5 && albedo_side.w > 0.0;
}

#endif // COMPARE_PROBES_SURFACE_GLSL
