// The glass pass's back faces (glass.py): for each pixel the nearest surface of a glass mesh whose normal
// faces away from the camera, as its outward normal and its plane's offset (n, dot(n, p)); zero where
// there is none. transmission.glsl intersects the refracted ray with that plane and refracts it out
// through that normal. Back faces by the normal, not the winding: a mesh's winding is not relied on.
// The second target holds the back face's glass share, glTF's (1 - metallic) x transmission with their maps:
// the light that leaves through it; the rest of it is opaque (a map's stripe, metal), whose inner side,
// lit only through the glass around it, is left out (dark).

#if defined VERTEX_SHADER

#include "world_vertex.glsl"
#include "material_vertex.glsl"

void main() {
    world_vertex();
    material_vertex();
}

#elif defined FRAGMENT_SHADER

in vec3 v_position;
in vec3 v_normal;

#include "material.glsl"

uniform vec3 u_camera_position;
uniform float u_transmission;   // glTF's transmission factor (transmission.glsl's)

layout(location = 0) out vec4 out_plane;
layout(location = 1) out vec4 out_share;

void main() {
    alpha_test();  // a masked-out texel is a hole, not a wall
    vec3 n = normalize(v_normal);
    if (dot(n, v_position - u_camera_position) <= 0.0) {
        discard;  // a front face
    }
    out_plane = vec4(n, dot(n, v_position));
    out_share = vec4(material_transmission(u_transmission) * (1.0 - clamp(material_metallic(), 0.0, 1.0)));
}

#endif
