// The glass pass's back faces (glass.py): for each pixel the nearest surface of a glass mesh whose normal
// faces away from the camera, as its outward normal and its plane's offset (n, dot(n, p)); zero where
// there is none. transmission.glsl intersects the refracted ray with that plane and refracts it out
// through that normal. Back faces by the normal, not the winding: a mesh's winding is not relied on.

#if defined VERTEX_SHADER

in vec3 in_position;
in vec3 in_normal;
uniform mat4 u_view_proj;

out vec3 v_position;
out vec3 v_normal;

void main() {
    v_position = in_position;
    v_normal = in_normal;
    gl_Position = u_view_proj * vec4(in_position, 1.0);
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
