// The glass pass's back faces (glass.py): for each pixel the nearest surface of a glass mesh whose normal
// faces away from the camera, as its outward normal and its plane's offset (n, dot(n, p)); zero where
// there is none. transmission.glsl intersects the refracted ray with that plane and refracts it out
// through that normal. Back faces by the normal, not the winding: a mesh's winding is not relied on.

#if defined VERTEX_SHADER

#include "world_vertex.glsl"

void main() {
    world_vertex();
}

#elif defined FRAGMENT_SHADER

in vec3 v_position;
in vec3 v_normal;
uniform vec3 u_camera_position;

out vec4 out_plane;

void main() {
    vec3 n = normalize(v_normal);
    if (dot(n, v_position - u_camera_position) <= 0.0) {
        discard;  // a front face
    }
    out_plane = vec4(n, dot(n, v_position));
}

#endif
