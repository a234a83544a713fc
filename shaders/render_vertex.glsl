// Vertex stage of the preview renderer: world-space position, normal, tangent.
in vec3 in_position;
in vec3 in_normal;
in vec3 in_tangent;

uniform mat4 view_projection;

out vec3 v_position;
out vec3 v_normal;
out vec3 v_tangent;

void main() {
    v_position = in_position;
    v_normal = in_normal;
    v_tangent = in_tangent;
    gl_Position = view_projection * vec4(in_position, 1.0);
}
