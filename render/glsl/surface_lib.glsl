// Surface noise (texton-noise section 6, Prop. 3): the GLSL twin of core/surface_noise.cpp, used
// by surface_noise.comp (points) and mesh_preview.frag (a mesh's fragments). Positions arrive split
// into an int32 texel and a float fraction so that y - x is formed from small exact integers and
// fractions, at any distance from the origin.

uniform sampler2D u_table; // alpha with u_pad zeros on every side (the level-0 table)
uniform int u_pad;
uniform int u_r;
uniform int u_order;
uniform int u_a;
uniform uvec2 u_seed;
uniform float u_norm; // 1 / sqrt(lambda r / 3)
uniform vec3 u_mean;

uint cell_key3(uvec2 seed, int cx, int cy, int cz) {
    uint h = mix32(seed.x ^ 0x3c6ef372u);
    h = absorb(h, seed.y);
    h = absorb(h, uint(cx));
    h = absorb(h, cx < 0 ? 0xffffffffu : 0u);
    h = absorb(h, uint(cy));
    h = absorb(h, cy < 0 ? 0xffffffffu : 0u);
    h = absorb(h, uint(cz));
    return absorb(h, cz < 0 ? 0xffffffffu : 0u);
}

int floor_div(int n, int a) { return n >= 0 ? n / a : -((-n + a - 1) / a); }

vec3 alpha(int i, int j) {
    if (i < 0 || j < 0 || i >= u_r || j >= u_r) return vec3(0.0);
    return texelFetch(u_table, ivec2(i + u_pad, j + u_pad), 0).rgb;
}

vec4 bspline3(float t) {
    float s = 1.0 - t;
    return vec4(s * s * s / 6.0, (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0,
                (3.0 * s * s * s - 6.0 * s * s + 4.0) / 6.0, t * t * t / 6.0);
}

// The texton centred on the origin (coefficients span [0, r - 1]).
vec3 texton(float z1, float z2) {
    float shift = 0.5 * float(u_r - 1);
    float x = z1 + shift, y = z2 + shift;
    float fx = floor(x), fy = floor(y);
    int ix = int(fx), iy = int(fy);
    if (u_order == 0) return alpha(ix, iy);
    float tx = x - fx, ty = y - fy;
    if (u_order == 1)
        return (1.0 - ty) * ((1.0 - tx) * alpha(ix, iy) + tx * alpha(ix + 1, iy)) +
               ty * ((1.0 - tx) * alpha(ix, iy + 1) + tx * alpha(ix + 1, iy + 1));
    vec4 wx = bspline3(tx), wy = bspline3(ty);
    vec3 v = vec3(0.0);
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) v += wy[j] * wx[i] * alpha(ix - 1 + i, iy - 1 + j);
    return v;
}

// The noise at y = yi + yf (texels) with unit normal n.
vec3 surface_noise(ivec3 yi, vec3 yf, vec3 n) {
    vec3 u1, u2; // Frisvad's frame, as on the CPU
    if (n.z < -0.9999999) {
        u1 = vec3(0.0, -1.0, 0.0);
        u2 = vec3(-1.0, 0.0, 0.0);
    } else {
        float a = 1.0 / (1.0 + n.z);
        float b = -n.x * n.y * a;
        u1 = vec3(1.0 - n.x * n.x * a, b, -n.x);
        u2 = vec3(b, 1.0 - n.y * n.y * a, -n.y);
    }
    float r = float(u_r);
    float half_r = 0.5 * r;
    // The cells that meet the bounding box of the contributing box and the slab (as on the CPU,
    // with a margin: a cell visited in vain only costs time).
    ivec3 lo, hi;
    for (int d = 0; d < 3; ++d) {
        float ext = (half_r + 2.0) * (abs(u1[d]) + abs(u2[d])) + half_r * abs(n[d]) + 0.01;
        lo[d] = floor_div(yi[d] + int(floor(yf[d] - ext)), u_a);
        hi[d] = floor_div(yi[d] + int(floor(yf[d] + ext)), u_a);
    }
    float cell_half = 0.5 * float(u_a) * (abs(n.x) + abs(n.y) + abs(n.z));
    vec3 acc = vec3(0.0);
    for (int cz = lo.z; cz <= hi.z; ++cz)
        for (int cy = lo.y; cy <= hi.y; ++cy)
            for (int cx = lo.x; cx <= hi.x; ++cx) {
                ivec3 cc = ivec3(cx, cy, cz);
                vec3 off = vec3(yi - cc * u_a) + yf - 0.5 * float(u_a);
                if (abs(dot(off, n)) - cell_half >= half_r + 0.01 * float(u_a)) continue;
                uint state = cell_key3(u_seed, cx, cy, cz);
                int count = poisson_count(next_draw(state));
                ivec3 cell = ivec3(cx, cy, cz);
                for (int i = 0; i < count; ++i) {
                    vec3 dv;
                    for (int k = 0; k < 3; ++k) {
                        int q;
                        uint f;
                        point_offset(next_draw(state), uint(u_a), q, f);
                        dv[k] = float(yi[k] - cell[k] * u_a - q) +
                                (yf[k] - float(f) * (1.0 / 16777216.0));
                    }
                    float eps = (next_draw(state) >> 31u) == 0u ? 1.0 : -1.0;
                    float w = 1.0 - 2.0 * abs(dot(dv, n)) / r;
                    if (w <= 0.0) continue;
                    float z1 = dot(dv, u1), z2 = dot(dv, u2);
                    if (abs(z1) >= half_r + 2.0 || abs(z2) >= half_r + 2.0) continue; // h = 0
                    acc += eps * w * texton(z1, z2);
                }
            }
    return u_mean + u_norm * acc;
}
