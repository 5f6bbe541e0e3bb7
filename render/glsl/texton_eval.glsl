// Texton noise at one pixel (texton-noise paper, section 8; NOISE_SPEC.md sections 6, 7 and 9):
// the uniforms and the evaluation shared by the fragment entry point (texton_noise.frag, what the
// engine kit's users draw) and the compute one the server runs (texton_noise.comp). Exact levels
// take every point in reach in the global order (cells by y then x, points in draw order) with
// the exact bilinear or cubic weights; mode 1 is the limit model.

// Per-tile parameters: uniforms for a single draw; in the server's batched compute path
// (TEXTOND_BATCH) plain globals that texton_noise.comp loads from the tile's record.
#ifdef TEXTOND_BATCH
#define TEXTOND_PARAM
#else
#define TEXTOND_PARAM uniform
#endif

uniform sampler2D u_table; // G, (L + 2 pad)^2 texels (pad 1, or 3 for order 3), texelFetch only
TEXTOND_PARAM int u_mode;        // 0 exact levels, 1 limit model
TEXTOND_PARAM int u_level;
TEXTOND_PARAM int u_st;          // texels per pixel (level >= 0)
TEXTOND_PARAM int u_sub_log2;    // -level (level < 0)
TEXTOND_PARAM int u_L;
TEXTOND_PARAM int u_r;
TEXTOND_PARAM int u_order;
TEXTOND_PARAM int u_a;
TEXTOND_PARAM uvec2 u_seed;
TEXTOND_PARAM uvec2 u_base_cx;
TEXTOND_PARAM uvec2 u_base_cy;
TEXTOND_PARAM ivec2 u_period;   // cells; 0 = unbounded
TEXTOND_PARAM ivec2 u_base_mod; // base cell mod period
TEXTOND_PARAM ivec2 u_origin;   // window origin relative to the base cell (texels, or pixels if level < 0)
TEXTOND_PARAM ivec2 u_offset;   // this draw's offset inside the window
TEXTOND_PARAM float u_scale;
TEXTOND_PARAM vec3 u_mean;
// limit model
TEXTOND_PARAM uvec2 u_q0x; // x0 - 2, 64-bit
TEXTOND_PARAM uvec2 u_q0y;
TEXTOND_PARAM float u_kappa[25];
TEXTOND_PARAM mat3 u_A;
TEXTOND_PARAM int u_channels;
// texture mixing (NOISE_SPEC.md section 9); positions relative to the base cell's origin
TEXTOND_PARAM int u_mix;                     // 0: one texton (u_table); 1: levels in u_level_tables
uniform sampler2DArray u_level_tables; // one layer a level, laid out as u_table
TEXTOND_PARAM int u_nlevels;
TEXTOND_PARAM int u_field;     // 0 ramp: rho = <p, u_rho_g> + u_rho_c; 1 mask
TEXTOND_PARAM vec2 u_rho_g;
TEXTOND_PARAM float u_rho_c;
uniform sampler2D u_mask; // R32F, read with texelFetch
TEXTOND_PARAM float u_mask_inv_scale;
TEXTOND_PARAM vec2 u_mask_o;    // mask pixel coordinate of the base cell's origin
TEXTOND_PARAM vec3 u_mean_u;
TEXTOND_PARAM vec3 u_mean_v;

float rho_at(vec2 p) {
    float r;
    if (u_field == 0) {
        r = dot(p, u_rho_g) + u_rho_c;
    } else {
        ivec2 sz = textureSize(u_mask, 0);
        vec2 f = clamp(p * u_mask_inv_scale + u_mask_o - 0.5, vec2(0.0), vec2(sz - 1));
        ivec2 i = min(ivec2(f), max(sz - 2, ivec2(0)));
        vec2 t = f - vec2(i);
        ivec2 j = min(i + 1, sz - 1);
        float m00 = texelFetch(u_mask, i, 0).r, m10 = texelFetch(u_mask, ivec2(j.x, i.y), 0).r;
        float m01 = texelFetch(u_mask, ivec2(i.x, j.y), 0).r, m11 = texelFetch(u_mask, j, 0).r;
        r = (1.0 - t.y) * ((1.0 - t.x) * m00 + t.x * m10) + t.y * ((1.0 - t.x) * m01 + t.x * m11);
    }
    return clamp(r, 0.0, 1.0);
}

int level_at(vec2 p) {
    float v = rho_at(p) * float(u_nlevels - 1) + 0.5;
    return v <= 0.0 ? 0 : min(int(v), u_nlevels - 1);
}

#ifdef TEXTOND_TABLE_BUFFER
// The server's compute path reads the tables from a buffer (layers of side^2 texels, a vec4 each):
// plain loads, where texelFetch cost llvmpipe most of its time.
layout(std430, binding = 3) readonly buffer Tables { vec4 u_tables[]; };
TEXTOND_PARAM int u_side;
TEXTOND_PARAM int u_table_base; // this tile's table in u_tables (vec4s)
vec3 table_at(int x, int y, int layer) {
    return u_tables[u_table_base + (layer * u_side + y) * u_side + x].rgb;
}
#else
vec3 table_at(int x, int y, int layer) {
    return u_mix != 0 ? texelFetch(u_level_tables, ivec3(x, y, layer), 0).rgb
                      : texelFetch(u_table, ivec2(x, y), 0).rgb;
}
#endif

// Table index t and fraction F' of one axis; false if out of reach (t in [0, L], or [-1, L + 1]
// for order 3).
bool axis_t(int x, int b, uint f, out int t, out uint fp) {
    if (u_level >= 0) {
        t = x - b + u_st - 1;
        fp = f;
    } else {
        int e = x - (b << u_sub_log2);
        int eq = e >> u_sub_log2;
        int er = e - (eq << u_sub_log2);
        int m = (er << (24 - u_sub_log2)) - int(f);
        if (m > 0) {
            t = eq + 1;
            fp = uint((1 << 24) - m);
        } else {
            t = eq;
            fp = uint(-m);
        }
    }
    int reach = u_order == 3 ? 1 : 0;
    return t >= -reach && t <= u_L + reach;
}

// Cubic B-spline weights of G[t + 4 - m], m = 0..3 (order 3; same operations as the CPU).
vec4 cubic_weights(uint fp) {
    precise float u = float(fp) * (1.0 / 16777216.0);
    precise float s = 1.0 - u;
    precise float u2 = u * u;
    precise float s2 = s * s;
    precise float u3 = u2 * u;
    precise float s3 = s2 * s;
    precise vec4 w;
    w.x = s3 / 6.0;
    w.y = ((3.0 * u3 - 6.0 * u2) + 4.0) / 6.0;
    w.z = ((3.0 * s3 - 6.0 * s2) + 4.0) / 6.0;
    w.w = u3 / 6.0;
    return w;
}

vec3 cubic_point(float eps, int tx, uint fx, int ty, uint fy, int layer) {
    vec4 wx = cubic_weights(fx), wy = cubic_weights(fy);
    precise vec3 v = vec3(0.0);
    for (int my = 0; my < 4; ++my) {
        precise float cy = eps * wy[my];
        for (int mx = 0; mx < 4; ++mx) {
            precise float c = cy * wx[mx];
            v = v + c * table_at(tx + 4 - mx, ty + 4 - my, layer);
        }
    }
    return v;
}

// Position of pixel `pix` relative to the base cell's origin: texels (level >= 0) or pixels
// (level < 0).
ivec2 pixel_position(ivec2 pix) {
    return u_level >= 0 ? u_origin + pix * u_st : u_origin + pix;
}

// The cells that can hold a point in reach of the pixel at x (non-negative by the choice of the
// base cell).
void reach_cells(ivec2 x, out ivec2 clo, out ivec2 chi) {
    ivec2 xt = u_level >= 0 ? x : (x >> u_sub_log2);
    int reach = u_order == 3 ? 1 : 0;
    ivec2 blo = (u_level >= 0 ? x - u_r : xt - u_r - 1) - reach;
    ivec2 bhi = (u_level >= 0 ? x + u_st - 1 : xt + 1) + reach;
    clo = blo / u_a;
    chi = bhi / u_a;
}

uint key_of_cell(int cx, int cy) {
    if (u_period.x > 0) {
        uvec2 kx = uvec2(uint((u_base_mod.x + cx) % u_period.x), 0u);
        uvec2 ky = uvec2(uint((u_base_mod.y + cy) % u_period.y), 0u);
        return cell_key(u_seed, kx, ky);
    }
    return cell_key(u_seed, add64(u_base_cx, cx), add64(u_base_cy, cy));
}

// The level table of a point of a mix at integer texel b and fraction f (0 for one texton).
int point_layer(ivec2 b, uvec2 f) {
    if (u_mix == 0) return 0;
    return level_at(vec2(float(b.x) + float(f.x) * (1.0 / 16777216.0),
                         float(b.y) + float(f.y) * (1.0 / 16777216.0)));
}

// What the point at integer texel b, fraction f adds to the pixel at x; false when out of reach.
bool point_term(ivec2 x, ivec2 b, uvec2 f, float eps, int layer, out vec3 term) {
    int tx, ty;
    uint fpx, fpy;
    term = vec3(0.0);
    if (!axis_t(x.x, b.x, f.x, tx, fpx)) return false;
    if (!axis_t(x.y, b.y, f.y, ty, fpy)) return false;
    if (u_order == 3) {
        term = cubic_point(eps, tx, fpx, ty, fpy, layer);
        return true;
    }
    float wx1 = u_order == 0 ? (fpx > 0u ? 1.0 : 0.0) : float(fpx) * (1.0 / 16777216.0);
    float wy1 = u_order == 0 ? (fpy > 0u ? 1.0 : 0.0) : float(fpy) * (1.0 / 16777216.0);
    float wx0 = 1.0 - wx1, wy0 = 1.0 - wy1;
    precise float cy0 = eps * wy0;
    precise float cy1 = eps * wy1;
    precise float c00 = cy0 * wx0;
    precise float c01 = cy0 * wx1;
    precise float c10 = cy1 * wx0;
    precise float c11 = cy1 * wx1;
    vec3 g11 = table_at(tx + 1, ty + 1, layer);
    vec3 g10 = table_at(tx, ty + 1, layer);
    vec3 g01 = table_at(tx + 1, ty, layer);
    vec3 g00 = table_at(tx, ty, layer);
    precise vec3 v = ((c00 * g11 + c01 * g10) + c10 * g01) + c11 * g00;
    term = v;
    return true;
}

// The pixel at x from its accumulated sum: the mean (the field's, for a mix) plus the scaled sum.
vec3 exact_value(ivec2 x, vec3 acc) {
    vec3 mean = u_mean;
    if (u_mix != 0) {
        // The mean where the pixel samples (k <= 0) or at its footprint's centre (k > 0).
        vec2 at = u_level >= 0 ? vec2(x) + 0.5 * float(u_st - 1)
                               : vec2(x) / float(1 << u_sub_log2);
        float rho = rho_at(at);
        mean = (1.0 - rho) * u_mean_u + rho * u_mean_v;
    }
    precise vec3 o = mean + u_scale * acc;
    return o;
}

// Per-pixel gather: every cell in reach, its points regenerated from the cell key.
vec3 exact_pixel(ivec2 pix) {
    ivec2 x = pixel_position(pix);
    ivec2 clo, chi;
    reach_cells(x, clo, chi);
    precise vec3 acc = vec3(0.0);
    for (int cy = clo.y; cy <= chi.y; ++cy) {
        for (int cx = clo.x; cx <= chi.x; ++cx) {
            uint state = key_of_cell(cx, cy);
            int n = poisson_count(next_draw(state));
            for (int i = 0; i < n; ++i) {
                int qx, qy;
                uint fx, fy;
                point_offset(next_draw(state), uint(u_a), qx, fx);
                point_offset(next_draw(state), uint(u_a), qy, fy);
                float eps = (next_draw(state) >> 31u) == 0u ? 1.0 : -1.0;
                ivec2 b = ivec2(cx * u_a + qx, cy * u_a + qy);
                vec3 term;
                if (point_term(x, b, uvec2(fx, fy), eps, point_layer(b, uvec2(fx, fy)), term))
                    acc = acc + term;
            }
        }
    }
    return exact_value(x, acc);
}

vec3 normals(uvec2 qx, uvec2 qy) {
    uint state = pixel_key(u_seed, u_level, qx, qy);
    vec3 z = vec3(0.0);
    for (int c = 0; c < u_channels; c += 2) {
        float u1 = float((next_draw(state) >> 8u) + 1u) * (1.0 / 16777216.0);
        float u2 = float(next_draw(state) >> 8u) * (1.0 / 16777216.0);
        float rr = sqrt(-2.0 * log(u1));
        z[c] = rr * cos(6.283185307179586 * u2);
        if (c + 1 < 3) z[c + 1] = rr * sin(6.283185307179586 * u2);
    }
    return z;
}

vec3 limit_pixel(ivec2 pix) {
    vec3 s = vec3(0.0);
    for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx)
            s += u_kappa[(dy + 2) * 5 + dx + 2] *
                 normals(add64(u_q0x, pix.x + 2 - dx), add64(u_q0y, pix.y + 2 - dy));
    return u_mean + u_A * s;
}

