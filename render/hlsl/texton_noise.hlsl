// HLSL (Shader Model 5+) translation of render/glsl/noise_lib.glsl + texton_noise.frag: the same
// function (render/NOISE_SPEC.md), the same uniforms, for Direct3D engines. Differences that are
// only syntax: 64-bit values are uint2(lo, hi); uniform arrays are packed four per 16-byte
// register (u_thresholds4, u_kappa4) because cbuffer arrays pad every element to 16 bytes; u_A is
// row_major. Run in textond's tests (tests/render/kit_shaders_test.cpp): glslang compiles it to
// SPIR-V with Direct3D's cbuffer offsets, SPIRV-Cross turns that into GLSL, OSMesa draws it, and
// every pixel is checked against the CPU backend.

Texture2D<float4> u_table : register(t0); // G, (L + 2 pad)^2 texels, RGB32F, read with Load only

cbuffer TextonNoise : register(b0) {
    int u_mode; // 0 exact levels, 1 limit model
    int u_level;
    int u_st;
    int u_sub_log2;
    int u_L;
    int u_r;
    int u_order;
    int u_a;
    uint2 u_seed;
    uint2 u_base_cx;
    uint2 u_base_cy;
    int2 u_period;
    int2 u_base_mod;
    int2 u_origin;
    int2 u_offset;
    float u_scale;
    float3 u_mean;
    uint2 u_q0x;
    uint2 u_q0y;
    row_major float3x3 u_A;
    int u_channels;
    int u_nthresholds;
    uint4 u_thresholds4[64]; // threshold j is u_thresholds4[j / 4][j % 4]
    float4 u_kappa4[7];      // kappa j is u_kappa4[j / 4][j % 4], j < 25
#ifdef TEXTOND_SET
    // A material set (material_noise.hlsl, which includes this file): after the texton's members,
    // so their offsets do not move.
    float4 u_set_mean0; // the mean of channels 0..3
    float4 u_set_mean1; // of channels 4..7
    int u_set_channels; // C, 1..8
    int u_height;       // the height's channel, or -1: no gradient
    float u_strength;   // normals: the texels a height step of 1 spans
#endif
};

uint mix32(uint x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

uint absorb(uint h, uint w) { return mix32(h ^ w); }

uint cell_key(uint2 seed, uint2 cx, uint2 cy) {
    uint h = mix32(seed.x ^ 0x6a09e667u);
    h = absorb(h, seed.y);
    h = absorb(h, cx.x);
    h = absorb(h, cx.y);
    h = absorb(h, cy.x);
    return absorb(h, cy.y);
}

uint pixel_key(uint2 seed, int level, uint2 px, uint2 py) {
    uint h = mix32(seed.x ^ 0xbb67ae85u);
    h = absorb(h, seed.y);
    h = absorb(h, (uint)level);
    h = absorb(h, px.x);
    h = absorb(h, px.y);
    h = absorb(h, py.x);
    return absorb(h, py.y);
}

uint next_draw(inout uint state) {
    state += 0x9e3779b9u;
    return mix32(state);
}

// a + b for a 64-bit a and a 32-bit signed b (GLSL's uaddCarry).
uint2 add64(uint2 a, int b) {
    uint lo = a.x + (uint)b;
    uint carry = lo < a.x ? 1u : 0u;
    return uint2(lo, a.y + carry + (b < 0 ? 0xffffffffu : 0u));
}

uint threshold(int j) { return u_thresholds4[j >> 2][j & 3]; }

int poisson_count(uint d0) {
    int lo = 0, hi = u_nthresholds;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (threshold(mid) <= d0)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

// High and low words of d * a (GLSL's umulExtended), from 16-bit halves.
void mul32x32(uint d, uint a, out uint hi, out uint lo) {
    uint d0 = d & 0xffffu, d1 = d >> 16, a0 = a & 0xffffu, a1 = a >> 16;
    uint p00 = d0 * a0, p01 = d0 * a1, p10 = d1 * a0, p11 = d1 * a1;
    uint mid = (p00 >> 16) + (p01 & 0xffffu) + (p10 & 0xffffu);
    lo = (p00 & 0xffffu) | (mid << 16);
    hi = p11 + (p01 >> 16) + (p10 >> 16) + (mid >> 16);
}

void point_offset(uint d, uint a, out int q, out uint f) {
    uint hi, lo;
    mul32x32(d, a, hi, lo);
    q = (int)hi;
    f = lo >> 8;
}

bool axis_t(int x, int b, uint f, out int t, out uint fp) {
    if (u_level >= 0) {
        t = x - b + u_st - 1;
        fp = f;
    } else {
        int e = x - (b << u_sub_log2);
        int eq = e >> u_sub_log2;
        int er = e - (eq << u_sub_log2);
        int m = (er << (24 - u_sub_log2)) - (int)f;
        if (m > 0) {
            t = eq + 1;
            fp = (uint)((1 << 24) - m);
        } else {
            t = eq;
            fp = (uint)(-m);
        }
    }
    int reach = u_order == 3 ? 1 : 0;
    return t >= -reach && t <= u_L + reach;
}

bool axis(int x, int b, uint f, out int t, out float w0, out float w1) {
    uint fp;
    w0 = 0.0;
    w1 = 0.0;
    if (!axis_t(x, b, f, t, fp)) return false;
    if (u_order == 0)
        w1 = fp > 0u ? 1.0 : 0.0;
    else
        w1 = (float)fp * (1.0 / 16777216.0);
    w0 = 1.0 - w1;
    return true;
}

float4 cubic_weights(uint fp) {
    precise float u = (float)fp * (1.0 / 16777216.0);
    precise float s = 1.0 - u;
    precise float u2 = u * u;
    precise float s2 = s * s;
    precise float u3 = u2 * u;
    precise float s3 = s2 * s;
    precise float4 w;
    w.x = s3 / 6.0;
    w.y = ((3.0 * u3 - 6.0 * u2) + 4.0) / 6.0;
    w.z = ((3.0 * s3 - 6.0 * s2) + 4.0) / 6.0;
    w.w = u3 / 6.0;
    return w;
}

float3 fetch(int x, int y) { return u_table.Load(int3(x, y, 0)).rgb; }

float3 cubic_point(float eps, int tx, uint fx, int ty, uint fy) {
    float4 wx = cubic_weights(fx), wy = cubic_weights(fy);
    precise float3 v = float3(0.0, 0.0, 0.0);
    for (int my = 0; my < 4; ++my) {
        precise float cy = eps * wy[my];
        for (int mx = 0; mx < 4; ++mx) {
            precise float c = cy * wx[mx];
            v = v + c * fetch(tx + 4 - mx, ty + 4 - my);
        }
    }
    return v;
}

float3 exact_pixel(int2 pix) {
    int2 x = u_level >= 0 ? u_origin + pix * u_st : u_origin + pix;
    int2 xt = u_level >= 0 ? x : (x >> u_sub_log2);
    int reach = u_order == 3 ? 1 : 0;
    int2 blo = (u_level >= 0 ? x - u_r : xt - u_r - 1) - reach;
    int2 bhi = (u_level >= 0 ? x + u_st - 1 : xt + 1) + reach;
    int2 clo = blo / u_a, chi = bhi / u_a;
    precise float3 acc = float3(0.0, 0.0, 0.0);
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
                if (u_order == 3) {
                    uint fpx, fpy;
                    if (!axis_t(x.x, cx * u_a + qx, fx, tx, fpx)) continue;
                    if (!axis_t(x.y, cy * u_a + qy, fy, ty, fpy)) continue;
                    acc = acc + cubic_point(eps, tx, fpx, ty, fpy);
                    continue;
                }
                float wx0, wx1, wy0, wy1;
                if (!axis(x.x, cx * u_a + qx, fx, tx, wx0, wx1)) continue;
                if (!axis(x.y, cy * u_a + qy, fy, ty, wy0, wy1)) continue;
                precise float cy0 = eps * wy0;
                precise float cy1 = eps * wy1;
                precise float c00 = cy0 * wx0;
                precise float c01 = cy0 * wx1;
                precise float c10 = cy1 * wx0;
                precise float c11 = cy1 * wx1;
                float3 g11 = fetch(tx + 1, ty + 1);
                float3 g10 = fetch(tx, ty + 1);
                float3 g01 = fetch(tx + 1, ty);
                float3 g00 = fetch(tx, ty);
                precise float3 v = ((c00 * g11 + c01 * g10) + c10 * g01) + c11 * g00;
                acc = acc + v;
            }
        }
    }
    precise float3 o = u_mean + u_scale * acc;
    return o;
}

float3 normals(uint2 qx, uint2 qy) {
    uint state = pixel_key(u_seed, u_level, qx, qy);
    float3 z = float3(0.0, 0.0, 0.0);
    for (int c = 0; c < u_channels; c += 2) {
        float u1 = (float)((next_draw(state) >> 8) + 1u) * (1.0 / 16777216.0);
        float u2 = (float)(next_draw(state) >> 8) * (1.0 / 16777216.0);
        float rr = sqrt(-2.0 * log(u1));
        z[c] = rr * cos(6.283185307179586 * u2);
        if (c + 1 < 3) z[c + 1] = rr * sin(6.283185307179586 * u2);
    }
    return z;
}

float3 limit_pixel(int2 pix) {
    float3 s = float3(0.0, 0.0, 0.0);
    for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) {
            int j = (dy + 2) * 5 + dx + 2;
            s += u_kappa4[j >> 2][j & 3] *
                 normals(add64(u_q0x, pix.x + 2 - dx), add64(u_q0y, pix.y + 2 - dy));
        }
    return u_mean + mul(u_A, s);
}

#ifndef TEXTOND_SET
float4 main(float4 position : SV_Position) : SV_Target {
    int2 pix = int2(position.xy) + u_offset;
    float3 v = u_mode == 0 ? exact_pixel(pix) : limit_pixel(pix);
    return float4(v, 1.0);
}
#endif
