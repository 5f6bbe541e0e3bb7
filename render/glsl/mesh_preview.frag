// Each fragment of the mesh: the surface noise at its interpolated position and normal
// (surface_lib.glsl), lit by one directional light as render/surface_eval.cpp's rasteriser does.
in vec3 v_pos;
in vec3 v_normal;
uniform vec3 u_fwd;   // the view direction: normals are turned to face the camera
uniform vec3 u_light; // unit
uniform int u_grey;   // one-channel texton: show its channel as grey
layout(location = 0) out vec4 o_color;

void main() {
    vec3 n = normalize(v_normal);
    if (dot(n, u_fwd) > 0.0) n = -n;
    vec3 fl = floor(v_pos);
    vec3 c = surface_noise(ivec3(fl), v_pos - fl, n);
    if (u_grey != 0) c = vec3(c.r);
    float shade = 0.35 + 0.65 * max(0.0, dot(n, u_light));
    o_color = vec4(clamp(c * shade, 0.0, 1.0), 1.0);
}
