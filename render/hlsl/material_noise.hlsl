// HLSL (Shader Model 5+) translation of render/glsl/material_eval.glsl + material_noise.frag: a
// material set's maps and its normal map in one point loop, to three render targets. It includes
// texton_noise.hlsl (the hash, the point process, the reach and the cbuffer, which gains the
// set's members under TEXTOND_SET); compile this file with texton_noise.hlsl beside it. Run in
// textond's tests like the texton's entry (tests/render/kit_shaders_test.cpp).
#define TEXTOND_SET
#include "texton_noise.hlsl"

Texture2D<float4> u_set_table0 : register(t1); // channels 0..3 of the level table, RGBA32F
Texture2D<float4> u_set_table1 : register(t2); // channels 4..7

struct SetTargets {
    float4 maps0 : SV_Target0;  // channels 0..3
    float4 maps1 : SV_Target1;  // channels 4..7
    float4 normal : SV_Target2; // n / 2 + 1/2 (tangent space, +Y up), or 0: no height
};

// Table index base - m has weight w[m] and derivative weight d[m] (material_eval.glsl).
int set_taps(int t, uint fp, out float4 w, out float4 d) {
    if (u_order == 3) {
        w = cubic_weights(fp);
        precise float u = (float)fp * (1.0 / 16777216.0);
        precise float s = 1.0 - u;
        d = float4(s * s / 2.0, (4.0 * u - 3.0 * u * u) / 2.0, (3.0 * s * s - 4.0 * s) / 2.0,
                   -u * u / 2.0);
        return t + 4;
    }
    float w1 = u_order == 0 ? (fp > 0u ? 1.0 : 0.0) : (float)fp * (1.0 / 16777216.0);
    w = float4(1.0 - w1, w1, 0.0, 0.0);
    d = float4(1.0, -1.0, 0.0, 0.0);
    return t + 1;
}

SetTargets main(float4 position : SV_Position) {
    int2 pix = int2(position.xy) + u_offset;
    int2 x = u_level >= 0 ? u_origin + pix * u_st : u_origin + pix;
    int2 xt = u_level >= 0 ? x : (x >> u_sub_log2);
    int reach = u_order == 3 ? 1 : 0;
    int2 blo = (u_level >= 0 ? x - u_r : xt - u_r - 1) - reach;
    int2 bhi = (u_level >= 0 ? x + u_st - 1 : xt + 1) + reach;
    int2 clo = blo / u_a, chi = bhi / u_a;
    int taps = u_order == 3 ? 4 : 2;
    precise float4 a0 = float4(0.0, 0.0, 0.0, 0.0);
    precise float4 a1 = float4(0.0, 0.0, 0.0, 0.0);
    precise float2 g = float2(0.0, 0.0);
    for (int cy = clo.y; cy <= chi.y; ++cy) {
        for (int cx = clo.x; cx <= chi.x; ++cx) {
            uint key;
            if (u_period.x > 0) {
                uint2 kx = uint2((uint)((u_base_mod.x + cx) % u_period.x), 0u);
                uint2 ky = uint2((uint)((u_base_mod.y + cy) % u_period.y), 0u);
                key = cell_key(u_seed, kx, ky);
            } else {
                key = cell_key(u_seed, add64(u_base_cx, cx), add64(u_base_cy, cy));
            }
            uint state = key;
            int n = poisson_count(next_draw(state));
            for (int i = 0; i < n; ++i) {
                int qx, qy;
                uint fx, fy;
                point_offset(next_draw(state), (uint)u_a, qx, fx);
                point_offset(next_draw(state), (uint)u_a, qy, fy);
                float eps = (next_draw(state) >> 31) == 0u ? 1.0 : -1.0;
                int tx, ty;
                uint fpx, fpy;
                if (!axis_t(x.x, cx * u_a + qx, fx, tx, fpx)) continue;
                if (!axis_t(x.y, cy * u_a + qy, fy, ty, fpy)) continue;
                float4 wx, dx, wy, dy;
                int ox = set_taps(tx, fpx, wx, dx);
                int oy = set_taps(ty, fpy, wy, dy);
                for (int my = 0; my < taps; ++my) {
                    precise float cy0 = eps * wy[my];
                    precise float dy0 = eps * dy[my];
                    for (int mx = 0; mx < taps; ++mx) {
                        int3 at = int3(ox - mx, oy - my, 0);
                        float4 t0 = u_set_table0.Load(at);
                        float4 t1 = u_set_channels > 4 ? u_set_table1.Load(at)
                                                       : float4(0.0, 0.0, 0.0, 0.0);
                        precise float c = cy0 * wx[mx];
                        a0 = a0 + c * t0;
                        a1 = a1 + c * t1;
                        if (u_height >= 0) {
                            float h = u_height < 4 ? t0[u_height] : t1[u_height - 4];
                            precise float cgx = cy0 * dx[mx];
                            precise float cgy = dy0 * wx[mx];
                            g = g + float2(cgx, cgy) * h;
                        }
                    }
                }
            }
        }
    }
    SetTargets o;
    o.maps0 = u_set_mean0 + u_scale * a0;
    o.maps1 = u_set_mean1 + u_scale * a1;
    precise float2 grad = u_scale * g;
    float3 nrm = normalize(float3(-u_strength * grad.x, u_strength * grad.y, 1.0));
    o.normal = u_height >= 0 ? float4(0.5 * nrm + 0.5, 1.0) : float4(0.0, 0.0, 0.0, 0.0);
    return o;
}
