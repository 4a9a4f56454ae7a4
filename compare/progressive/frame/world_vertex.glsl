// The vertex stage of a pass that shades the meshes in world space (the G-buffer, the glass's back faces):
// the vertex's world position and normal pass through to the fragment stage (v_position, v_normal), and
// u_view_proj places it on the screen (call world_vertex() in main).

in vec3 in_position;
in vec3 in_normal;
uniform mat4 u_view_proj;

out vec3 v_position;
out vec3 v_normal;

void world_vertex() {
    v_position = in_position;
    v_normal = in_normal;
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
