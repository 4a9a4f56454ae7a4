// Shadow pass: distance from the light sample point to the nearest surface, one face
// of the five-face half-cube at a time (the viewport selects the face's atlas tile).
//
// The depth written is the Euclidean distance from the sample point divided by the
// far distance (gl_FragDepth), not the perspective depth: the five faces share one
// metric, the lookup's bias is in world units, and the 24-bit depth has the same
// absolute precision (far / 2^24) at every distance.
//
// Define MOMENTS (variance shadow maps, shadow.py): the pass also writes the first two
// moments (d, d^2) of the distance d in world units to an RG32F colour attachment; the
// depth test still keeps the nearest surface.
//
// Define ORTHO (a directional light's orthographic map, punctual.py): the depth is the distance
// along u_direction from the plane through u_sample instead, the metric of a parallel projection.
//
// With ALPHA_MASK (and TEXTURES, material.glsl) the holes of alpha-masked materials let light through.

#if defined VERTEX_SHADER

in vec3 in_position;
#include "material_vertex.glsl"

uniform mat4 u_view_proj;

out vec3 v_position;

void main() {
    v_position = in_position;
    material_vertex();
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}

#elif defined FRAGMENT_SHADER

in vec3 v_position;

#include "material.glsl"

uniform vec3 u_sample;
uniform float u_inv_far;
#if defined ORTHO
uniform vec3 u_direction;
#endif

#if defined MOMENTS
out vec2 out_moments;
#endif

void main() {
    alpha_test();
#if defined ORTHO
    gl_FragDepth = clamp(dot(v_position - u_sample, u_direction) * u_inv_far, 0.0, 1.0);
#else
    gl_FragDepth = clamp(distance(v_position, u_sample) * u_inv_far, 0.0, 1.0);
#endif
#if defined MOMENTS
    float d = distance(v_position, u_sample);
    out_moments = vec2(d, d * d);
#endif
}

#endif
