// Surface noise at points with normals (surface_lib.glsl): u_in holds 12 words a point (3 ints,
// 3 float fractions, 3 float normals, 3 unused); u_out receives 4 floats a point.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer In { uint u_in[]; };
layout(std430, binding = 1) writeonly buffer Out { float u_out[]; };

uniform int u_count;

void main() {
    int p = int(gl_GlobalInvocationID.x);
    if (p >= u_count) return;
    ivec3 yi = ivec3(int(u_in[12 * p]), int(u_in[12 * p + 1]), int(u_in[12 * p + 2]));
    vec3 yf = vec3(uintBitsToFloat(u_in[12 * p + 3]), uintBitsToFloat(u_in[12 * p + 4]),
                   uintBitsToFloat(u_in[12 * p + 5]));
    vec3 n = normalize(vec3(uintBitsToFloat(u_in[12 * p + 6]), uintBitsToFloat(u_in[12 * p + 7]),
                            uintBitsToFloat(u_in[12 * p + 8])));
    vec3 o = surface_noise(yi, yf, n);
    u_out[4 * p] = o.r;
    u_out[4 * p + 1] = o.g;
    u_out[4 * p + 2] = o.b;
    u_out[4 * p + 3] = 1.0;
}
