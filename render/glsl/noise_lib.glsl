// Texton noise, NOISE_SPEC.md sections 2-4 and 7, on 32-bit words only. The C++ twin is
// core/noise_hash.h + core/grid_poisson.h; both are tested against render/noise_vectors.json.
// 64-bit values travel as uvec2(lo, hi).

uint mix32(uint x) {
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

uint absorb(uint h, uint w) { return mix32(h ^ w); }

uint cell_key(uvec2 seed, uvec2 cx, uvec2 cy) {
    uint h = mix32(seed.x ^ 0x6a09e667u);
    h = absorb(h, seed.y);
    h = absorb(h, cx.x);
    h = absorb(h, cx.y);
    h = absorb(h, cy.x);
    return absorb(h, cy.y);
}

uint pixel_key(uvec2 seed, int level, uvec2 px, uvec2 py) {
    uint h = mix32(seed.x ^ 0xbb67ae85u);
    h = absorb(h, seed.y);
    h = absorb(h, uint(level));
    h = absorb(h, px.x);
    h = absorb(h, px.y);
    h = absorb(h, py.x);
    return absorb(h, py.y);
}

uint next_draw(inout uint state) {
    state += 0x9e3779b9u;
    return mix32(state);
}

// a + b for a 64-bit a and a 32-bit signed b.
uvec2 add64(uvec2 a, int b) {
    uint carry;
    uint lo = uaddCarry(a.x, uint(b), carry);
    return uvec2(lo, a.y + carry + (b < 0 ? 0xffffffffu : 0u));
}

#ifdef TEXTOND_BATCH
// The server's batched compute path: each tile's thresholds in one buffer, from u_thr_base.
layout(std430, binding = 5) readonly buffer Thresholds { uint u_thr[]; };
int u_thr_base;
int u_nthresholds;
uint threshold_at(int i) { return u_thr[u_thr_base + i]; }
#else
uniform uint u_thresholds[256];
uniform int u_nthresholds;
uint threshold_at(int i) { return u_thresholds[i]; }
#endif

int poisson_count(uint d0) {
    int lo = 0, hi = u_nthresholds;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (threshold_at(mid) <= d0)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

// Integer texel offset q and 24-bit fraction F of a draw in a cell of side a.
void point_offset(uint d, uint a, out int q, out uint f) {
    uint hi, lo;
    umulExtended(d, a, hi, lo);
    q = int(hi);
    f = lo >> 8u;
}
