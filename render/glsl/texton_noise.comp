// Texton noise as compute (NOISE_SPEC.md section 7; texton-noise paper, section 8), what the
// server's OpenGL backends run: one invocation a pixel in 16 x 16 groups, written with
// imageStore. Compiled after noise_lib.glsl and texton_eval.glsl.
//
// Exact levels read the window's points from a buffer (u_list = 1) where the host generated them
// once, cells by y then x and points in draw order, with each cell's start in u_offsets: a pixel
// walks the rows of its cells (one contiguous run each) and sums the points in reach in that
// order, the per-pixel gather's sums term for term, with no hashing per pixel. Where the window
// holds far more points than pixels (levels above 1), each pixel regenerates its own cells'
// points instead (u_list = 0). No barriers: llvmpipe runs a shader that has any as coroutines,
// which made every path of it 1.5x slower.

layout(local_size_x = 16, local_size_y = 16) in;
layout(rgba32f, binding = 0) uniform writeonly image2D u_out;
layout(std430, binding = 1) readonly buffer CellStarts { uint u_offsets[]; };
// x, y (texels from the base cell), fx | negative << 31, fy | level table << 24
layout(std430, binding = 2) readonly buffer Points { uvec4 u_points[]; };
uniform ivec2 u_size;  // pixels of this dispatch (from u_offset in the window)
uniform int u_list;
uniform ivec2 u_cells; // cells of the window, from the base cell

vec3 exact_listed(ivec2 pix) {
    ivec2 x = pixel_position(pix);
    ivec2 clo, chi;
    reach_cells(x, clo, chi);
    precise vec3 acc = vec3(0.0);
    for (int cy = clo.y; cy <= chi.y; ++cy) {
        uint end = u_offsets[cy * u_cells.x + chi.x + 1];
        for (uint i = u_offsets[cy * u_cells.x + clo.x]; i < end; ++i) {
            uvec4 p = u_points[i];
            float eps = (p.z >> 31u) == 0u ? 1.0 : -1.0;
            vec3 term;
            if (point_term(x, ivec2(p.xy), uvec2(p.z & 0xffffffu, p.w & 0xffffffu), eps,
                           int(p.w >> 24u), term))
                acc = acc + term;
        }
    }
    return exact_value(x, acc);
}

void main() {
    ivec2 local = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(local, u_size))) return;
    ivec2 pix = local + u_offset;
    vec3 v = u_mode == 1 ? limit_pixel(pix) : (u_list == 1 ? exact_listed(pix) : exact_pixel(pix));
    imageStore(u_out, local, vec4(v, 1.0));
}
