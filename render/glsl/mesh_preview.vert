// The mesh preview (surface noise on an OBJ): positions in mesh units; v_pos in texels.
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
uniform mat4 u_mvp;
uniform float u_scale; // texels per mesh unit
out vec3 v_pos;
out vec3 v_normal;

void main() {
    v_pos = a_pos * u_scale;
    v_normal = a_normal;
    gl_Position = u_mvp * vec4(a_pos, 1.0);
}
