// A material set's maps and its height's gradient at one pixel, in one point loop (engine kit;
// core/material_set.h, render/normal_map.h): the maps side by side are one C-channel texton
// (C <= 8) driven by one Poisson process, so each point's taps are read once for every map, and
// the derivative of the interpolation kernel applied to the height's channel gives the gradient
// exactly (texton-noise section 8; NOISE_SPEC.md sections 6 and 7). Needs noise_lib.glsl and
// texton_eval.glsl before it (their uniforms, the point process and the reach); exact levels only
// (u_mode 0, level < limit_level of textond_kit.json).

uniform sampler2D u_set_table0; // channels 0..3 of the level table, RGBA32F, laid out as u_table
uniform sampler2D u_set_table1; // channels 4..7 (zeros for a set of 4 channels or fewer)
uniform int u_set_channels;     // C, 1..8
uniform int u_height;           // the height's channel, or -1: no gradient
uniform vec4 u_set_mean0;       // the mean of channels 0..3
uniform vec4 u_set_mean1;       // of channels 4..7

struct SetPixel {
    vec4 c0;   // channels 0..3
    vec4 c1;   // channels 4..7
    vec2 grad; // the height's derivative along x and along rows, per texel
};

// The taps of one axis: table index `base - m` has weight w[m] and derivative weight d[m]
// (m < 2, or 4 for order 3). The table coordinate is t + 1 - u (t + 3 - u for order 3), so the
// derivative in texels is -d/du; order 0 has none.
int set_taps(int t, uint fp, out vec4 w, out vec4 d) {
    if (u_order == 3) {
        w = cubic_weights(fp);
        precise float u = float(fp) * (1.0 / 16777216.0);
        precise float s = 1.0 - u;
        d = vec4(s * s / 2.0, (4.0 * u - 3.0 * u * u) / 2.0, (3.0 * s * s - 4.0 * s) / 2.0,
                 -u * u / 2.0);
        return t + 4;
    }
    float w1 = u_order == 0 ? (fp > 0u ? 1.0 : 0.0) : float(fp) * (1.0 / 16777216.0);
    w = vec4(1.0 - w1, w1, 0.0, 0.0);
    d = vec4(1.0, -1.0, 0.0, 0.0);
    return t + 1;
}

SetPixel set_pixel(ivec2 pix) {
    ivec2 x = pixel_position(pix);
    ivec2 clo, chi;
    reach_cells(x, clo, chi);
    int taps = u_order == 3 ? 4 : 2;
    precise vec4 a0 = vec4(0.0);
    precise vec4 a1 = vec4(0.0);
    precise vec2 g = vec2(0.0);
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
                int tx, ty;
                uint fpx, fpy;
                if (!axis_t(x.x, cx * u_a + qx, fx, tx, fpx)) continue;
                if (!axis_t(x.y, cy * u_a + qy, fy, ty, fpy)) continue;
                vec4 wx, dx, wy, dy;
                int ox = set_taps(tx, fpx, wx, dx);
                int oy = set_taps(ty, fpy, wy, dy);
                for (int my = 0; my < taps; ++my) {
                    precise float cy0 = eps * wy[my];
                    precise float dy0 = eps * dy[my];
                    for (int mx = 0; mx < taps; ++mx) {
                        ivec2 at = ivec2(ox - mx, oy - my);
                        vec4 t0 = texelFetch(u_set_table0, at, 0);
                        vec4 t1 = u_set_channels > 4 ? texelFetch(u_set_table1, at, 0) : vec4(0.0);
                        precise float c = cy0 * wx[mx];
                        a0 = a0 + c * t0;
                        a1 = a1 + c * t1;
                        if (u_height >= 0) {
                            float h = u_height < 4 ? t0[u_height] : t1[u_height - 4];
                            precise float cgx = cy0 * dx[mx];
                            precise float cgy = dy0 * wx[mx];
                            g = g + vec2(cgx, cgy) * h;
                        }
                    }
                }
            }
        }
    }
    SetPixel s;
    s.c0 = u_set_mean0 + u_scale * a0;
    s.c1 = u_set_mean1 + u_scale * a1;
    s.grad = u_scale * g;
    return s;
}
