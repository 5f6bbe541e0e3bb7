// Texton noise as compute (NOISE_SPEC.md section 7; texton-noise paper, section 8), what the
// server's OpenGL backends run, in batches: one dispatch evaluates many windows (tiles, or the
// pieces of a large frame), one 16 x 16 group of pixels per workgroup and one window per
// workgroup layer z. Compiled after noise_lib.glsl and texton_eval.glsl with TEXTOND_BATCH and
// TEXTOND_TABLE_BUFFER defined, and TEXTOND_OUT_U8, TEXTOND_OUT_U16 or neither (floats).
//
// Each window's parameters are a record of 25 uvec4 in u_tiles (render/gl/noise_window.cpp
// writes them). Its pixels go to u_out from the record's out_base, row by row, quantised here to
// the bits the response needs (8 bits: one word a pixel, RGBA; 16: two; floats: three words) as
// the encoder rounds (clamp to [0, 1], times 255 or 65535, plus 0.5, truncated): an 8-bit tile
// reads back a quarter of the bytes of RGBA floats and encodes to the same bytes.
//
// Two kernels, the same bits. On llvmpipe, exact levels read the window's points from a buffer
// (list = 1) where the host generated them once, cells by y then x and points in draw order, with
// each cell's start in u_offsets: a pixel walks the rows of its cells (one contiguous run each)
// and sums the points in reach in that order, the per-pixel gather's sums term for term, with no
// hashing per pixel. Where the window holds far more points than pixels (levels above 1), each
// pixel regenerates its own cells' points instead (list = 0). That kernel has no barriers:
// llvmpipe runs a shader that has any as coroutines, which made every path of it 1.5x slower.
// On a GPU (TEXTOND_SHARED_POINTS), the host lists nothing: each workgroup draws its cells'
// points once into shared memory (exact_shared).

layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 0) writeonly buffer Out { uint u_out[]; };
layout(std430, binding = 1) readonly buffer CellStarts { uint u_offsets[]; };
// x, y (texels from the base cell), fx | negative << 31, fy | level table << 24
layout(std430, binding = 2) readonly buffer Points { uvec4 u_points[]; };
layout(std430, binding = 4) readonly buffer Tiles { uvec4 u_tiles[]; };
uniform int u_tile_first; // this dispatch's first record

const int kRecord = 25; // uvec4 a record
ivec2 t_size;           // pixels of this window (piece)
uint t_out_base;        // its first pixel in u_out
int t_list, t_cell_base, t_point_base;
ivec2 t_cells; // cells of the window, from the base cell

float f_at(uint w) { return uintBitsToFloat(w); }

void load_tile(int t) {
    int b = t * kRecord;
    uvec4 r;
    r = u_tiles[b + 0];
    u_mode = int(r.x);
    u_level = int(r.y);
    u_st = int(r.z);
    u_sub_log2 = int(r.w);
    r = u_tiles[b + 1];
    u_L = int(r.x);
    u_r = int(r.y);
    u_order = int(r.z);
    u_a = int(r.w);
    r = u_tiles[b + 2];
    u_seed = r.xy;
    u_base_cx = r.zw;
    r = u_tiles[b + 3];
    u_base_cy = r.xy;
    u_q0x = r.zw;
    r = u_tiles[b + 4];
    u_q0y = r.xy;
    u_nthresholds = int(r.z);
    u_thr_base = int(r.w);
    r = u_tiles[b + 5];
    u_period = ivec2(r.xy);
    u_base_mod = ivec2(r.zw);
    r = u_tiles[b + 6];
    u_origin = ivec2(r.xy);
    u_offset = ivec2(r.zw);
    r = u_tiles[b + 7];
    t_size = ivec2(r.xy);
    t_out_base = r.z;
    u_channels = int(r.w);
    r = u_tiles[b + 8];
    u_side = int(r.x);
    u_table_base = int(r.y);
    t_list = int(r.z);
    t_cell_base = int(r.w);
    r = u_tiles[b + 9];
    t_cells = ivec2(r.xy);
    t_point_base = int(r.z);
    u_mix = int(r.w);
    r = u_tiles[b + 10];
    u_mean = vec3(f_at(r.x), f_at(r.y), f_at(r.z));
    u_scale = f_at(r.w);
    if (u_mode == 1) {
        for (int i = 0; i < 25; ++i) u_kappa[i] = f_at(u_tiles[b + 11 + i / 4][i % 4]);
        uvec4 r0 = u_tiles[b + 18], r1 = u_tiles[b + 19], r2 = u_tiles[b + 20];
        // Stored as rows; mat3() takes columns.
        u_A = transpose(mat3(f_at(r0.x), f_at(r0.y), f_at(r0.z), f_at(r1.x), f_at(r1.y),
                             f_at(r1.z), f_at(r2.x), f_at(r2.y), f_at(r2.z)));
    }
    if (u_mix != 0) {
        r = u_tiles[b + 21];
        u_field = int(r.x);
        u_rho_g = vec2(f_at(r.y), f_at(r.z));
        u_rho_c = f_at(r.w);
        r = u_tiles[b + 22];
        u_mask_inv_scale = f_at(r.x);
        u_mask_o = vec2(f_at(r.y), f_at(r.z));
        u_nlevels = int(r.w);
        r = u_tiles[b + 23];
        u_mean_u = vec3(f_at(r.x), f_at(r.y), f_at(r.z));
        r = u_tiles[b + 24];
        u_mean_v = vec3(f_at(r.x), f_at(r.y), f_at(r.z));
    }
}

vec3 exact_listed(ivec2 pix) {
    ivec2 x = pixel_position(pix);
    ivec2 clo, chi;
    reach_cells(x, clo, chi);
    precise vec3 acc = vec3(0.0);
    for (int cy = clo.y; cy <= chi.y; ++cy) {
        int row = t_cell_base + cy * t_cells.x;
        uint end = u_offsets[row + chi.x + 1];
        for (uint i = u_offsets[row + clo.x]; i < end; ++i) {
            uvec4 p = u_points[uint(t_point_base) + i];
            float eps = (p.z >> 31u) == 0u ? 1.0 : -1.0;
            vec3 term;
            if (point_term(x, ivec2(p.xy), uvec2(p.z & 0xffffffu, p.w & 0xffffffu), eps,
                           int(p.w >> 24u), term))
                acc = acc + term;
        }
    }
    return exact_value(x, acc);
}

#ifdef TEXTOND_SHARED_POINTS
// A GPU's path (TEXTOND_SHARED_POINTS = the list's capacity, from the device's shared memory):
// the workgroup draws the points of every cell its 16 x 16 pixels reach once into shared memory,
// one invocation a cell, cells by y then x; each pixel then walks the runs of its own cells,
// exactly as exact_listed walks the host's list, so the sums are term for term the per-pixel
// gather's. A group whose cells or points overflow the list evaluates exact_pixel instead. Not
// compiled for llvmpipe, which runs any shader with a barrier as coroutines (1.5x slower).
const int kSharedCells = 256;
shared uint s_start[kSharedCells + 1];
shared uvec4 s_points[TEXTOND_SHARED_POINTS];

// The group's cells [lo, lo + n) from the first pixel's reach to its last inside pixel's; false
// when they or their points do not fit the list. Called by every invocation (barriers).
bool draw_group_points(out ivec2 lo, out ivec2 n) {
    ivec2 g0 = ivec2(gl_WorkGroupID.xy * 16u) + u_offset;
    ivec2 g1 = min(g0 + 15, u_offset + t_size - 1);
    ivec2 unused, hi;
    reach_cells(pixel_position(g0), lo, unused);
    reach_cells(pixel_position(g1), unused, hi);
    n = hi - lo + 1;
    int cells = n.x * n.y;
    if (cells > kSharedCells) return false;
    int me = int(gl_LocalInvocationIndex);
    for (int c = me; c < cells; c += 256) {
        uint state = key_of_cell(lo.x + c % n.x, lo.y + c / n.x);
        s_start[c + 1] = uint(poisson_count(next_draw(state)));
    }
    memoryBarrierShared();
    barrier();
    if (me == 0) {
        s_start[0] = 0u;
        for (int c = 0; c < cells; ++c) s_start[c + 1] += s_start[c];
    }
    memoryBarrierShared();
    barrier();
    if (s_start[cells] > uint(TEXTOND_SHARED_POINTS)) return false;
    for (int c = me; c < cells; c += 256) {
        int cx = lo.x + c % n.x, cy = lo.y + c / n.x;
        uint state = key_of_cell(cx, cy);
        int count = poisson_count(next_draw(state));
        uint k = s_start[c];
        for (int i = 0; i < count; ++i) {
            int qx, qy;
            uint fx, fy;
            point_offset(next_draw(state), uint(u_a), qx, fx);
            point_offset(next_draw(state), uint(u_a), qy, fy);
            uint negative = next_draw(state) >> 31u;
            ivec2 b = ivec2(cx * u_a + qx, cy * u_a + qy);
            uint layer = uint(point_layer(b, uvec2(fx, fy)));
            s_points[k + uint(i)] = uvec4(uvec2(b), fx | (negative << 31u), fy | (layer << 24u));
        }
    }
    memoryBarrierShared();
    barrier();
    return true;
}

vec3 exact_shared(ivec2 pix, bool inside) {
    ivec2 lo, n;
#ifdef TEXTOND_MARK_OVERFLOW
    if (!draw_group_points(lo, n)) return vec3(-1e30); // tests: which path ran
#else
    if (!draw_group_points(lo, n)) return inside ? exact_pixel(pix) : vec3(0.0);
#endif
    if (!inside) return vec3(0.0);
    ivec2 x = pixel_position(pix);
    ivec2 clo, chi;
    reach_cells(x, clo, chi);
    clo -= lo;
    chi -= lo;
    precise vec3 acc = vec3(0.0);
    for (int cy = clo.y; cy <= chi.y; ++cy) {
        int row = cy * n.x;
        uint end = s_start[row + chi.x + 1];
        for (uint i = s_start[row + clo.x]; i < end; ++i) {
            uvec4 p = s_points[i];
            float eps = (p.z >> 31u) == 0u ? 1.0 : -1.0;
            vec3 term;
            if (point_term(x, ivec2(p.xy), uvec2(p.z & 0xffffffu, p.w & 0xffffffu), eps,
                           int(p.w >> 24u), term))
                acc = acc + term;
        }
    }
    return exact_value(x, acc);
}
#endif

// The encoder's rounding (server/io/image_io.cpp, interleave), operation for operation.
uint quantise(float v, float scale) {
    precise float s = clamp(v, 0.0, 1.0) * scale;
    precise float h = s + 0.5;
    return uint(h);
}

void main() {
    load_tile(u_tile_first + int(gl_WorkGroupID.z));
    ivec2 local = ivec2(gl_WorkGroupID.xy * 16u + gl_LocalInvocationID.xy);
    bool inside = all(lessThan(local, t_size));
    ivec2 pix = local + u_offset;
#ifdef TEXTOND_SHARED_POINTS
    // The record is the group's, so these returns leave whole groups (uniform control flow).
    if (any(greaterThanEqual(ivec2(gl_WorkGroupID.xy * 16u), t_size))) return;
    vec3 v = vec3(0.0);
    if (u_mode == 0 && t_list == 0) v = exact_shared(pix, inside);
    if (!inside) return;
    if (u_mode == 1) v = limit_pixel(pix);
    if (u_mode == 0 && t_list == 1) v = exact_listed(pix);
#else
    if (!inside) return;
    vec3 v = u_mode == 1 ? limit_pixel(pix) : (t_list == 1 ? exact_listed(pix) : exact_pixel(pix));
#endif
    uint k = t_out_base + uint(local.y * t_size.x + local.x);
#if defined(TEXTOND_OUT_U8)
    u_out[k] = quantise(v.r, 255.0) | (quantise(v.g, 255.0) << 8) |
               (quantise(v.b, 255.0) << 16) | 0xff000000u;
#elif defined(TEXTOND_OUT_U16)
    u_out[2u * k] = quantise(v.r, 65535.0) | (quantise(v.g, 65535.0) << 16);
    u_out[2u * k + 1u] = quantise(v.b, 65535.0) | 0xffff0000u;
#else
    u_out[3u * k] = floatBitsToUint(v.r);
    u_out[3u * k + 1u] = floatBitsToUint(v.g);
    u_out[3u * k + 2u] = floatBitsToUint(v.b);
#endif
}
