#include "render/cpu_backend.h"

#include "core/fft2d.h"
#include "core/grid_poisson.h"
#include "core/noise_levels.h"
#include "render/cancel.h"
#include "render/image_buffers.h"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace textond::render {

using core::noise::CellPoint;
using core::noise::floor_div;
using core::noise::GridPoisson;

namespace {

// One axis of the footprints of a block's points: for output index i (from `first`), the table
// index t[at + i] and the weights of G[t + 1] and G[t] (orders 0, 1), or of G[t + 4 - m],
// m = 0..3 (order 3, in w0..w3) (NOISE_SPEC.md section 7). Found once a point for all channels:
// at zoomed-out levels a point reaches a few pixels, and finding them cost more than adding it.
struct TapStore {
    std::vector<int> t;
    std::vector<float> w0, w1, w2, w3;
    void clear() {
        t.clear();
        w0.clear();
        w1.clear();
        w2.clear();
        w3.clear();
    }
};
struct TapRange {
    std::int64_t first = 0; // first output coordinate covered
    int count = 0;
    std::size_t at = 0; // into the store
};

struct LevelGeometry {
    int level = 0;
    std::int64_t st = 1;  // texels per pixel (k >= 0)
    std::int64_t sub = 1; // pixels per texel (k < 0)
    int length = 0;       // L
    int order = 1;
    int reach = 0;  // order 3 reaches one texel further on each side: t in [-1, L + 1]
    int deriv = -1; // 0 or 1: the derivative along x or y (texels) instead of the value
};

inline void weights(int order, std::uint32_t f, float& w0, float& w1) {
    if (order == 0)
        w1 = f > 0 ? 1.0f : 0.0f;
    else
        w1 = static_cast<float>(f) * (1.0f / 16777216.0f);
    w0 = 1.0f - w1;
}

// Cubic B-spline weights of G[t + 4 - m], m = 0..3, at fraction u = F' 2^-24 (NOISE_SPEC.md
// section 7; texton-noise section 10, order 3).
inline void cubic_weights(std::uint32_t f, float w[4]) {
    const float u = static_cast<float>(f) * (1.0f / 16777216.0f);
    const float s = 1.0f - u;
    const float u2 = u * u, s2 = s * s;
    const float u3 = u2 * u, s3 = s2 * s;
    w[0] = s3 / 6.0f;
    w[1] = ((3.0f * u3 - 6.0f * u2) + 4.0f) / 6.0f;
    w[2] = ((3.0f * s3 - 6.0f * s2) + 4.0f) / 6.0f;
    w[3] = u3 / 6.0f;
}

// The derivatives of those weights with respect to the pixel's position in texels, for the
// gradient of a material set's height (render/normal_map.h). The table coordinate is t + 1 - u
// (orders 0, 1) or t + 3 - u (order 3), so d/dX = -d/du; order 0 has none (a.e. zero).
inline void derivative_weights(std::uint32_t f, float& w0, float& w1) {
    (void)f;
    w0 = 1.0f;  // G[t + 1]
    w1 = -1.0f; // G[t]
}
inline void cubic_derivative_weights(std::uint32_t f, float w[4]) {
    const float u = static_cast<float>(f) * (1.0f / 16777216.0f);
    const float s = 1.0f - u;
    w[0] = s * s / 2.0f;
    w[1] = (4.0f * u - 3.0f * u * u) / 2.0f;
    w[2] = (3.0f * s * s - 4.0f * s) / 2.0f;
    w[3] = -u * u / 2.0f;
}
// The weights along `axis` (0 = x, 1 = y): the value's, or the derivative's on the axis asked.
inline void axis_weights(const LevelGeometry& g, int axis, std::uint32_t f, float& w0, float& w1) {
    if (g.deriv == axis)
        derivative_weights(f, w0, w1);
    else
        weights(g.order, f, w0, w1);
}
inline void axis_cubic_weights(const LevelGeometry& g, int axis, std::uint32_t f, float w[4]) {
    if (g.deriv == axis)
        cubic_derivative_weights(f, w);
    else
        cubic_weights(f, w);
}

// Output coordinates [p0, p1) of the block, base b and fraction f of the point on this axis.
TapRange axis_taps(const LevelGeometry& g, int axis, std::int64_t p0, std::int64_t p1,
                   std::int64_t b, std::uint32_t f, TapStore& store) {
    TapRange out;
    out.at = store.t.size();
    std::int64_t lo, hi; // candidate output range, inclusive
    if (g.level >= 0) {
        // t = st P - b + st - 1 in [-reach, L + reach]
        lo = -floor_div(-(b - g.st + 1 - g.reach), g.st); // ceil
        hi = floor_div(b + g.length - g.st + 1 + g.reach, g.st);
    } else {
        lo = g.sub * (b - 1 - g.reach);
        hi = g.sub * (b + g.length + 1 + g.reach);
    }
    lo = std::max(lo, p0);
    hi = std::min(hi, p1 - 1);
    out.first = lo;
    for (std::int64_t p = lo; p <= hi; ++p) {
        std::int64_t t;
        std::uint32_t fp;
        if (g.level >= 0) {
            t = g.st * p - b + g.st - 1;
            fp = f;
        } else {
            const std::int64_t e = p - g.sub * b;
            const std::int64_t eq = floor_div(e, g.sub), er = e - g.sub * eq;
            const std::int64_t m = er * (std::int64_t{1} << (24 + g.level)) - f;
            if (m > 0) {
                t = eq + 1;
                fp = static_cast<std::uint32_t>((std::int64_t{1} << 24) - m);
            } else {
                t = eq;
                fp = static_cast<std::uint32_t>(-m);
            }
        }
        if (t < -g.reach || t > g.length + g.reach) {
            if (out.count == 0) {
                out.first = p + 1;
                continue;
            }
            break; // t is monotone in p: nothing further on this side
        }
        store.t.push_back(static_cast<int>(t));
        float w[4] = {0, 0, 0, 0};
        if (g.order == 3)
            axis_cubic_weights(g, axis, fp, w);
        else
            axis_weights(g, axis, fp, w[0], w[1]);
        store.w0.push_back(w[0]);
        store.w1.push_back(w[1]);
        store.w2.push_back(w[2]);
        store.w3.push_back(w[3]);
        ++out.count;
    }
    return out;
}

// One point's whole footprint in one channel (level 0; zoomed-out levels through phase planes).
// Along a row the weights are constant and the table columns contiguous, so the inner loop
// vectorises; cloned per instruction set, with the same bits on each (no FMA contraction, the
// same operation order per element).
constexpr int kRunQuantum = 16; // floats per AVX-512 vector; LevelTable and blocks pad for it

// Orders 0 and 1: a point's footprint as runs of pixels, each reading four runs of table texels
// (a1 = G[ty + 1][tx + 1], a0 = G[ty + 1][tx], b1 = G[ty][tx + 1], b0 = G[ty][tx] at the first
// pixel; a row down is g_stride floats down). Level 0 reads the table itself; zoomed-out levels
// its phase planes (LevelTable::phase_row), where the texels of consecutive pixels are
// consecutive too.
struct RunSplat {
    float* acc = nullptr;       // first accumulator of the footprint
    std::size_t acc_stride = 0; // floats per block row
    const float *a1 = nullptr, *a0 = nullptr, *b1 = nullptr, *b0 = nullptr;
    std::size_t g_stride = 0; // floats per table (or phase) row
    int rows = 0, cols = 0;
    float c00 = 0, c01 = 0, c10 = 0, c11 = 0;
};

__attribute__((target_clones("avx512f", "avx2", "default"))) void splat_runs(const RunSplat& s) {
    const float c00 = s.c00, c01 = s.c01, c10 = s.c10, c11 = s.c11;
    // Runs are padded to whole vectors: past the footprint the table holds zeros (each pixel then
    // gets + 0, which changes no bit) and past the block the accumulators have slack columns.
    const int n = (s.cols + kRunQuantum - 1) / kRunQuantum * kRunQuantum;
    for (int i = 0; i < s.rows; ++i) {
        float* __restrict acc = s.acc + s.acc_stride * i;
        const float* __restrict a1 = s.a1 + s.g_stride * i;
        const float* __restrict a0 = s.a0 + s.g_stride * i;
        const float* __restrict b1 = s.b1 + s.g_stride * i;
        const float* __restrict b0 = s.b0 + s.g_stride * i;
#pragma GCC ivdep
        for (int j = 0; j < n; ++j)
            acc[j] += ((c00 * a1[j] + c01 * a0[j]) + c10 * b1[j]) + c11 * b0[j];
    }
}

// Level 0, order 3: the same contiguous runs with 4 x 4 taps; g = G[ty0 + 4][tx0 + 4] (the
// weight-0 tap of the first pixel) and c[my * 4 + mx] = (eps wy[my]) wx[mx].
struct ContiguousCubic {
    float* acc;
    std::size_t acc_stride;
    const float* g;
    std::size_t g_stride;
    int rows, cols;
    float c[16];
};

__attribute__((target_clones("avx512f", "avx2", "default"))) void
splat_contiguous_cubic(const ContiguousCubic& s) {
    const int n = (s.cols + kRunQuantum - 1) / kRunQuantum * kRunQuantum;
    float c[16];
    for (int i = 0; i < 16; ++i) c[i] = s.c[i];
    for (int i = 0; i < s.rows; ++i) {
        float* __restrict acc = s.acc + s.acc_stride * i;
        const float* __restrict g0 = s.g + s.g_stride * i; // G[ty + 4]
        const float* __restrict g1 = g0 - s.g_stride;
        const float* __restrict g2 = g1 - s.g_stride;
        const float* __restrict g3 = g2 - s.g_stride;
#pragma GCC ivdep
        for (int j = 0; j < n; ++j) {
            float v = 0.0f;
            v += c[0] * g0[j];
            v += c[1] * g0[j - 1];
            v += c[2] * g0[j - 2];
            v += c[3] * g0[j - 3];
            v += c[4] * g1[j];
            v += c[5] * g1[j - 1];
            v += c[6] * g1[j - 2];
            v += c[7] * g1[j - 3];
            v += c[8] * g2[j];
            v += c[9] * g2[j - 1];
            v += c[10] * g2[j - 2];
            v += c[11] * g2[j - 3];
            v += c[12] * g3[j];
            v += c[13] * g3[j - 1];
            v += c[14] * g3[j - 2];
            v += c[15] * g3[j - 3];
            acc[j] += v;
        }
    }
}

// One axis of a zoomed-out footprint: output coordinates [lo, hi] of the block where
// t = st P - b + st - 1 lies in [0, L] (NOISE_SPEC.md section 7), and t at lo.
bool phase_span(const LevelGeometry& g, std::int64_t p0, std::int64_t p1, std::int64_t b,
                std::int64_t& lo, std::int64_t& hi, std::int64_t& t0) {
    lo = std::max(p0, -floor_div(-(b - g.st + 1), g.st));
    hi = std::min(p1 - 1, floor_div(b + g.length - g.st + 1, g.st));
    t0 = g.st * lo - b + g.st - 1;
    return lo <= hi;
}

void splat_row_general(float* __restrict acc, const float* __restrict g1,
                       const float* __restrict g0, const TapStore& s, const TapRange& x, float cy0,
                       float cy1) {
    const int* tt = s.t.data() + x.at;
    const float* w0 = s.w0.data() + x.at;
    const float* w1 = s.w1.data() + x.at;
    for (int j = 0; j < x.count; ++j) {
        const int t = tt[j];
        const float wx0 = w0[j], wx1 = w1[j];
        const float c00 = cy0 * wx0, c01 = cy0 * wx1, c10 = cy1 * wx0, c11 = cy1 * wx1;
        acc[j] += ((c00 * g1[t + 1] + c01 * g1[t]) + c10 * g0[t + 1]) + c11 * g0[t];
    }
}

// Order 3: g[m] = G[ty + 4 - m] for the row's table index ty, cy[m] = eps wy_m. The 16 products
// are summed in the order of NOISE_SPEC.md section 7 (m_y major, then m_x).
void splat_row_cubic(float* __restrict acc, const float* const g[4], const TapStore& s,
                     const TapRange& x, const float cy[4]) {
    for (int j = 0; j < x.count; ++j) {
        const std::size_t js = x.at + static_cast<std::size_t>(j);
        const int t = s.t[js];
        const float wx[4] = {s.w0[js], s.w1[js], s.w2[js], s.w3[js]};
        float v = 0.0f;
        for (int my = 0; my < 4; ++my)
            for (int mx = 0; mx < 4; ++mx) v += (cy[my] * wx[mx]) * g[my][t + 4 - mx];
        acc[j] += v;
    }
}

// What a block lists and accumulates, reused from block to block (a fresh 200 kB vector a block
// costs page faults) through a process-wide pool, not kept a thread: every connection thread
// renders and libgomp gives each a team of its own, so scratch kept at its largest by some 150
// threads grew a replica serving level-3 tiles of a small texton (1.2 million points a tile) to
// 1.9 GB. The pool keeps one set a core, each of at most kKeptSetBytes.
struct BlockScratch {
    std::vector<float> acc;
    std::vector<CellPoint> pts;
    std::vector<int> point_level;
    std::vector<RunSplat> phase_points;
    TapStore taps;
    std::vector<std::pair<TapRange, TapRange>> ranges;
    std::vector<double> rho;

    std::size_t bytes() const {
        return acc.capacity() * sizeof(float) + pts.capacity() * sizeof(CellPoint) +
               point_level.capacity() * sizeof(int) + phase_points.capacity() * sizeof(RunSplat) +
               taps.t.capacity() * sizeof(int) +
               (taps.w0.capacity() + taps.w1.capacity() + taps.w2.capacity() + taps.w3.capacity()) *
                   sizeof(float) +
               ranges.capacity() * sizeof(ranges[0]) + rho.capacity() * sizeof(double);
    }
};

constexpr std::size_t kKeptSetBytes = std::size_t{32} << 20;

class ScratchPool {
public:
    std::unique_ptr<BlockScratch> take() {
        const std::lock_guard<std::mutex> lock(m_mutex);
        if (m_free.empty()) return std::make_unique<BlockScratch>();
        auto s = std::move(m_free.back());
        m_free.pop_back();
        return s;
    }
    void give(std::unique_ptr<BlockScratch> s) {
        if (s->bytes() > kKeptSetBytes) return;
        const std::lock_guard<std::mutex> lock(m_mutex);
        if (m_free.size() < m_kept) m_free.push_back(std::move(s));
    }

private:
    std::mutex m_mutex;
    std::vector<std::unique_ptr<BlockScratch>> m_free;
    const std::size_t m_kept = std::max(2u, std::thread::hardware_concurrency());
};

ScratchPool& scratch_pool() {
    static ScratchPool pool;
    return pool;
}

// One set for the scope of a block.
class ScratchLease {
public:
    ScratchLease() : m_set(scratch_pool().take()) {}
    ~ScratchLease() { scratch_pool().give(std::move(m_set)); }
    ScratchLease(const ScratchLease&) = delete;
    ScratchLease& operator=(const ScratchLease&) = delete;
    BlockScratch* operator->() const { return m_set.get(); }

private:
    std::unique_ptr<BlockScratch> m_set;
};

struct Block {
    std::int64_t x0, y0; // global output coordinates
    int w, h;
};

// Cells whose points may reach output coordinates [p0, p1) on one axis.
void cell_range(const LevelGeometry& g, int a, std::int64_t p0, std::int64_t p1, std::int64_t& c0,
                std::int64_t& c1) {
    const int r = g.level > 0 ? g.length - static_cast<int>(g.st) + 1 : g.length;
    std::int64_t b_lo, b_hi; // bases b that can reach the range
    if (g.level >= 0) {
        b_lo = g.st * p0 - r - g.reach;
        b_hi = g.st * (p1 - 1) + g.st - 1 + g.reach;
    } else {
        b_lo = floor_div(p0, g.sub) - r - 1 - g.reach;
        b_hi = floor_div(p1 - 1, g.sub) + 1 + g.reach;
    }
    c0 = floor_div(b_lo, a);
    c1 = floor_div(b_hi, a);
}

// A point's RunSplat at a zoomed-out level (the table's phase planes) in channel 0 of the block's
// accumulators (`acc`, `stride` floats a row);
// rows = 0 when it does not reach the block.
RunSplat phase_splat(const LevelGeometry& geo, const LevelTable& table, const CellPoint& p,
                     const Block& blk, float* acc, std::size_t stride) {
    RunSplat sp{};
    std::int64_t xa, xb, tx, ya, yb, ty;
    if (!phase_span(geo, blk.x0, blk.x0 + blk.w, p.bx, xa, xb, tx) ||
        !phase_span(geo, blk.y0, blk.y0 + blk.h, p.by, ya, yb, ty))
        return sp;
    float wx0, wx1, wy0, wy1;
    axis_weights(geo, 0, p.fx, wx0, wx1);
    axis_weights(geo, 1, p.fy, wy0, wy1);
    const float cy0w = p.eps * wy0, cy1w = p.eps * wy1;
    const auto st = static_cast<int>(geo.st);
    const auto mx0 = static_cast<int>(tx % st), jx0 = static_cast<int>(tx / st);
    const auto mx1 = static_cast<int>((tx + 1) % st), jx1 = static_cast<int>((tx + 1) / st);
    const auto my0 = static_cast<int>(ty % st), jy0 = static_cast<int>(ty / st);
    const auto my1 = static_cast<int>((ty + 1) % st), jy1 = static_cast<int>((ty + 1) / st);
    sp.acc_stride = stride;
    sp.acc = acc + static_cast<std::size_t>(ya - blk.y0) * stride +
             static_cast<std::size_t>(xa - blk.x0);
    sp.a1 = table.phase_row(0, my1, mx1, jy1) + jx1;
    sp.a0 = table.phase_row(0, my1, mx0, jy1) + jx0;
    sp.b1 = table.phase_row(0, my0, mx1, jy0) + jx1;
    sp.b0 = table.phase_row(0, my0, mx0, jy0) + jx0;
    sp.g_stride = table.phase_stride;
    sp.rows = static_cast<int>(yb - ya + 1);
    sp.cols = static_cast<int>(xb - xa + 1);
    sp.c00 = cy0w * wx0;
    sp.c01 = cy0w * wx1;
    sp.c10 = cy1w * wx0;
    sp.c11 = cy1w * wx1;
    return sp;
}

// `tables` holds one table (a texton) or one per mix level (`mix` set): then every point takes
// the table of the level of the field at its own position (texton-noise section 7).
// The CPU kernel's inner loop, the one function of render/ over 120 lines, on purpose: the point
// loop, the tap loops and their accumulators are one body for the compiler to keep in registers
// (measure with `textond bench render` before splitting it).
// NOLINTNEXTLINE(readability-function-size)
void render_block(const PreparedTexton& tex, const std::vector<const LevelTable*>& tables,
                  const PreparedMix* mix, const GridPoisson& grid, const LevelGeometry& geo,
                  const NoiseRequest& q, const Block& blk, core::Image& out, std::uint64_t& points,
                  std::uint64_t& evaluations) {
    const int nc = tex.channels();
    const std::size_t stride = static_cast<std::size_t>(blk.w) + kRunQuantum;
    const std::size_t plane = stride * blk.h;
    const ScratchLease scratch;
    std::vector<float>& acc = scratch->acc;
    acc.assign(plane * nc, 0.0f);
    std::int64_t cx0, cx1, cy0, cy1;
    cell_range(geo, grid.a, blk.x0, blk.x0 + blk.w, cx0, cx1);
    cell_range(geo, grid.a, blk.y0, blk.y0 + blk.h, cy0, cy1);
    // All points that may reach the block, in the global order (cells by y then x, points in
    // draw order); then one channel at a time, so the accumulators and the table of that
    // channel stay in L1/L2 while every point is added.
    std::vector<CellPoint>& pts = scratch->pts;
    pts.clear();
    for (std::int64_t cy = cy0; cy <= cy1; ++cy)
        for (std::int64_t cx = cx0; cx <= cx1; ++cx) grid.cell_points(q.seed, cx, cy, pts);
    points += pts.size();
    std::vector<int>& point_level = scratch->point_level;
    point_level.assign(pts.size(), 0);
    if (mix)
        for (std::size_t i = 0; i < pts.size(); ++i)
            point_level[i] = mix->level_at(static_cast<double>(pts[i].bx) + pts[i].fx / 16777216.0,
                                           static_cast<double>(pts[i].by) + pts[i].fy / 16777216.0);
    // Zoomed-out levels of orders 0 and 1 read the tables split by phase; other levels find
    // every point's taps on both axes, once for all channels.
    const bool phased = geo.level > 0 && geo.order <= 1;
    TapStore& store = scratch->taps;
    std::vector<std::pair<TapRange, TapRange>>& ranges = scratch->ranges;
    store.clear();
    ranges.clear();
    std::vector<RunSplat>& phase_points = scratch->phase_points;
    phase_points.clear();
    if (phased)
        for (std::size_t pi = 0; pi < pts.size(); ++pi)
            phase_points.push_back(phase_splat(geo,
                                               *tables[static_cast<std::size_t>(point_level[pi])],
                                               pts[pi], blk, acc.data(), stride));
    if (geo.level != 0 && !phased)
        for (const CellPoint& p : pts) {
            TapRange tx = axis_taps(geo, 0, blk.x0, blk.x0 + blk.w, p.bx, p.fx, store), ty;
            if (tx.count > 0) ty = axis_taps(geo, 1, blk.y0, blk.y0 + blk.h, p.by, p.fy, store);
            ranges.emplace_back(tx, ty);
        }
    for (int c = 0; c < nc; ++c)
        for (std::size_t pi = 0; pi < pts.size(); ++pi) {
            const CellPoint& p = pts[pi];
            const LevelTable& table = *tables[static_cast<std::size_t>(point_level[pi])];
            if (geo.level == 0 && geo.order == 3) {
                // t = P - b in [-1, L + 1]: contiguous, constant weights.
                const std::int64_t xa = std::max(blk.x0, p.bx - 1),
                                   xb = std::min(blk.x0 + blk.w - 1, p.bx + geo.length + 1);
                const std::int64_t ya = std::max(blk.y0, p.by - 1),
                                   yb = std::min(blk.y0 + blk.h - 1, p.by + geo.length + 1);
                if (xa > xb || ya > yb) continue;
                float wx[4], wy[4];
                axis_cubic_weights(geo, 0, p.fx, wx);
                axis_cubic_weights(geo, 1, p.fy, wy);
                ContiguousCubic sp;
                for (int my = 0; my < 4; ++my) {
                    const float cyw = p.eps * wy[my];
                    for (int mx = 0; mx < 4; ++mx) sp.c[my * 4 + mx] = cyw * wx[mx];
                }
                sp.acc_stride = stride;
                sp.acc = acc.data() + plane * c +
                         static_cast<std::size_t>(ya - blk.y0) * sp.acc_stride +
                         static_cast<std::size_t>(xa - blk.x0);
                sp.g_stride = table.stride;
                sp.g = table.row(c, static_cast<int>(ya - p.by) + 4) + (xa - p.bx) + 4;
                sp.rows = static_cast<int>(yb - ya + 1);
                sp.cols = static_cast<int>(xb - xa + 1);
                splat_contiguous_cubic(sp);
                if (c == 0) evaluations += static_cast<std::uint64_t>(sp.rows) * sp.cols;
                continue;
            }
            if (geo.level == 0) {
                // t = P - b in [0, L]: a contiguous run of pixels, constant weights.
                const std::int64_t xa = std::max(blk.x0, p.bx),
                                   xb = std::min(blk.x0 + blk.w - 1, p.bx + geo.length);
                const std::int64_t ya = std::max(blk.y0, p.by),
                                   yb = std::min(blk.y0 + blk.h - 1, p.by + geo.length);
                if (xa > xb || ya > yb) continue;
                float wx0, wx1, wy0, wy1;
                axis_weights(geo, 0, p.fx, wx0, wx1);
                axis_weights(geo, 1, p.fy, wy0, wy1);
                const float cy0w = p.eps * wy0, cy1w = p.eps * wy1;
                RunSplat sp;
                sp.acc_stride = stride;
                sp.acc = acc.data() + plane * c +
                         static_cast<std::size_t>(ya - blk.y0) * sp.acc_stride +
                         static_cast<std::size_t>(xa - blk.x0);
                sp.g_stride = table.stride;
                sp.b0 = table.row(c, static_cast<int>(ya - p.by)) + (xa - p.bx); // G[ty][tx]
                sp.b1 = sp.b0 + 1;
                sp.a0 = sp.b0 + table.stride;
                sp.a1 = sp.a0 + 1;
                sp.rows = static_cast<int>(yb - ya + 1);
                sp.cols = static_cast<int>(xb - xa + 1);
                sp.c00 = cy0w * wx0;
                sp.c01 = cy0w * wx1;
                sp.c10 = cy1w * wx0;
                sp.c11 = cy1w * wx1;
                splat_runs(sp);
                if (c == 0) evaluations += static_cast<std::uint64_t>(sp.rows) * sp.cols;
                continue;
            }
            if (phased) {
                RunSplat sp = phase_points[pi]; // channel 0's
                if (sp.rows == 0) continue;
                const std::size_t shift = table.phase_channel_size() * static_cast<std::size_t>(c);
                sp.acc += plane * static_cast<std::size_t>(c);
                sp.a1 += shift;
                sp.a0 += shift;
                sp.b1 += shift;
                sp.b0 += shift;
                splat_runs(sp);
                if (c == 0) evaluations += static_cast<std::uint64_t>(sp.rows) * sp.cols;
                continue;
            }
            const auto& [tx, ty] = ranges[pi];
            if (tx.count == 0 || ty.count == 0) continue;
            if (c == 0) evaluations += static_cast<std::uint64_t>(tx.count) * ty.count;
            const int col = static_cast<int>(tx.first - blk.x0);
            const int row0 = static_cast<int>(ty.first - blk.y0);
            if (geo.order == 3) {
                for (int i = 0; i < ty.count; ++i) {
                    const std::size_t is = ty.at + static_cast<std::size_t>(i);
                    const int t = store.t[is];
                    const float cyw[4] = {p.eps * store.w0[is], p.eps * store.w1[is],
                                          p.eps * store.w2[is], p.eps * store.w3[is]};
                    const float* rows[4] = {table.row(c, t + 4), table.row(c, t + 3),
                                            table.row(c, t + 2), table.row(c, t + 1)};
                    float* a =
                        acc.data() + plane * c + static_cast<std::size_t>(row0 + i) * stride + col;
                    splat_row_cubic(a, rows, store, tx, cyw);
                }
                continue;
            }
            for (int i = 0; i < ty.count; ++i) {
                const std::size_t is = ty.at + static_cast<std::size_t>(i);
                const int t = store.t[is];
                const float cyw0 = p.eps * store.w0[is];
                const float cyw1 = p.eps * store.w1[is];
                float* a =
                    acc.data() + plane * c + static_cast<std::size_t>(row0 + i) * stride + col;
                splat_row_general(a, table.row(c, t + 1), table.row(c, t), store, tx, cyw0, cyw1);
            }
        }
    const float scale = static_cast<float>(1.0 / std::sqrt(grid.lambda));
    const std::int64_t ox = blk.x0 - q.x0, oy = blk.y0 - q.y0;
    // A mix's field at every pixel of the block, once for all channels.
    std::vector<double>& rho = scratch->rho;
    if (mix) {
        rho.resize(static_cast<std::size_t>(blk.w) * blk.h);
        for (int y = 0; y < blk.h; ++y) {
            const double py = pixel_texel(geo.level, blk.y0 + y);
            for (int x = 0; x < blk.w; ++x)
                rho[static_cast<std::size_t>(y) * blk.w + x] =
                    mix->field().rho(pixel_texel(geo.level, blk.x0 + x), py);
        }
    }
    for (int c = 0; c < nc; ++c) {
        // A derivative has no mean.
        const float m = geo.deriv >= 0
                            ? 0.0f
                            : static_cast<float>(tex.texton().mean[static_cast<std::size_t>(c)]);
        for (int y = 0; y < blk.h; ++y) {
            const float* a = acc.data() + plane * c + static_cast<std::size_t>(y) * stride;
            float* o = &out.at(c, static_cast<int>(ox), static_cast<int>(oy) + y);
            if (mix) {
                const double* r = rho.data() + static_cast<std::size_t>(y) * blk.w;
                for (int x = 0; x < blk.w; ++x)
                    o[x] = static_cast<float>(mix->mean_of(r[x], c)) + scale * a[x];
                continue;
            }
            for (int x = 0; x < blk.w; ++x) o[x] = m + scale * a[x];
        }
    }
}

// The limit model of a mix: each pixel takes the model of the level at its footprint's centre.
bool render_limit_mix(const PreparedMix& mix, const NoiseRequest& q, int threads,
                      core::Image& out) {
    const int nc = mix.channels();
    LevelGeometry geo;
    geo.level = q.level;
    geo.st = std::int64_t{1} << q.level;
    // Every level's model once (each lookup takes the texton's lock), and the window's normals
    // once: each pixel's 5 x 5 taps share them with its neighbours, as in render_limit.
    std::vector<const core::noise::LimitModel*> models;
    models.reserve(static_cast<std::size_t>(mix.levels()));
    for (int l = 0; l < mix.levels(); ++l) models.push_back(&mix.level(l).limit(q.level));
    const int zw = q.width + 4, zh = q.height + 4;
    std::vector<float> z(static_cast<std::size_t>(zw) * zh * 3);
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int y = 0; y < zh; ++y)
        for (int x = 0; x < zw; ++x)
            core::noise::pixel_normals(q.seed, q.level, q.x0 - 2 + x, q.y0 - 2 + y, nc,
                                       &z[(static_cast<std::size_t>(y) * zw + x) * 3]);
    std::atomic<bool> skipped{false};
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int y = 0; y < q.height; ++y) {
        if (stopped(q.cancel)) {
            skipped = true;
            continue;
        }
        const double ty = pixel_texel(geo.level, q.y0 + y);
        for (int x = 0; x < q.width; ++x) {
            const double tx = pixel_texel(geo.level, q.x0 + x);
            const double rho = mix.field().rho(tx, ty);
            const core::noise::LimitModel& lm =
                *models[static_cast<std::size_t>(mix.level_of(rho))];
            float s[3] = {0, 0, 0};
            for (int dy = -2; dy <= 2; ++dy)
                for (int dx = -2; dx <= 2; ++dx) {
                    // z(P - D): pixel (x - dx, y - dy) sits at (x + 2 - dx, y + 2 - dy) in z.
                    const float* n =
                        &z[(static_cast<std::size_t>(y + 2 - dy) * zw + (x + 2 - dx)) * 3];
                    const float k = static_cast<float>(
                        lm.kappa[static_cast<std::size_t>((dy + 2) * 5 + dx + 2)]);
                    for (int c = 0; c < nc; ++c) s[c] = s[c] + k * n[c];
                }
            for (int c = 0; c < nc; ++c) {
                float v = 0.0f;
                for (int d = 0; d < nc; ++d) v = v + static_cast<float>(lm.a(c, d)) * s[d];
                out.at(c, x, y) = static_cast<float>(mix.mean_of(rho, c)) + v;
            }
        }
    }
    return !skipped;
}

bool render_limit(const PreparedTexton& tex, const NoiseRequest& q, int threads, core::Image& out) {
    const int nc = tex.channels();
    const core::noise::LimitModel& lm = tex.limit(q.level);
    const int nz = lm.a.n; // normals per pixel: the texton's channels, or its set's
    const int zw = q.width + 4, zh = q.height + 4;
    const std::size_t zplane = static_cast<std::size_t>(zw) * zh;
    std::vector<float> z(zplane * nz); // planar, so the 5x5 filter below vectorises
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int y = 0; y < zh; ++y)
        for (int x = 0; x < zw; ++x) {
            float n[core::kMaxChannels];
            core::noise::pixel_normals(q.seed, q.level, q.x0 - 2 + x, q.y0 - 2 + y, nz, n);
            for (int c = 0; c < nz; ++c)
                z[zplane * c + static_cast<std::size_t>(y) * zw + x] = n[c];
        }
    float kappa[25];
    for (int i = 0; i < 25; ++i)
        kappa[i] = static_cast<float>(lm.kappa[static_cast<std::size_t>(i)]);
    float a[core::kMaxChannels][core::kMaxChannels], mean[core::kMaxChannels];
    for (int c = 0; c < nc; ++c) {
        mean[c] = static_cast<float>(tex.texton().mean[static_cast<std::size_t>(c)]);
        for (int d = 0; d < nz; ++d) a[c][d] = static_cast<float>(lm.a(lm.first + c, d));
    }
    const int w = q.width;
    std::atomic<bool> skipped{false};
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int y = 0; y < q.height; ++y) {
        if (stopped(q.cancel)) {
            skipped = true;
            continue;
        }
        std::vector<float> s(static_cast<std::size_t>(w) * nz, 0.0f);
        for (int c = 0; c < nz; ++c) {
            float* sc = s.data() + static_cast<std::size_t>(w) * c;
            // Pixel P reads z(P - D), D in [-2, 2]^2, in row-major order from D = (-2, -2).
            for (int dy = -2; dy <= 2; ++dy)
                for (int dx = -2; dx <= 2; ++dx) {
                    const float k = kappa[(dy + 2) * 5 + dx + 2];
                    const float* zr =
                        z.data() + zplane * c + static_cast<std::size_t>(y + 2 - dy) * zw + 2 - dx;
                    for (int x = 0; x < w; ++x) sc[x] = sc[x] + k * zr[x];
                }
        }
        for (int c = 0; c < nc; ++c) {
            float* o = &out.at(c, 0, y);
            for (int x = 0; x < w; ++x) {
                float v = 0.0f;
                for (int d = 0; d < nz; ++d)
                    v = v + a[c][d] * s[static_cast<std::size_t>(w) * d + x];
                o[x] = mean[c] + v;
            }
        }
    }
    return !skipped;
}

} // namespace

CpuBackend::CpuBackend(int threads, int block)
    : m_threads(core::resolve_threads(threads)), m_block(std::max(16, block)) {}

std::string CpuBackend::renderer() const {
    const char* isa = __builtin_cpu_supports("avx512f") ? "avx512f"
                      : __builtin_cpu_supports("avx2")  ? "avx2"
                                                        : "sse2";
    return "cpu (" + std::to_string(m_threads) + " threads, " + isa + ")";
}

Result<core::Image> CpuBackend::render(const PreparedTexton& tex, const NoiseRequest& q,
                                       RenderStats* stats) {
    assert(!tex.check(q)); // checked by the caller (backend.h)
    auto out = render_gaussian(tex, q, stats);
    if (out && q.marginals == Marginals::exemplar)
        restore_marginals(*tex.marginals(q.level), out.value());
    return out;
}

Result<core::Image> CpuBackend::render_gaussian(const PreparedTexton& tex, const NoiseRequest& q,
                                                RenderStats* stats) {
    if (q.level >= tex.limit_level()) {
        core::Image out(q.width, q.height, tex.channels());
        if (!render_limit(tex, q, m_threads, out)) return abandoned(q.cancel, "the render");
        if (stats) {
            stats->limit_model = true;
            stats->points = 0;
            stats->evaluations = static_cast<std::uint64_t>(q.width) * q.height * 25 +
                                 static_cast<std::uint64_t>(q.width + 4) * (q.height + 4);
        }
        return out;
    }
    const auto table = tex.table(q.level);
    return render_exact(tex, {table.get()}, nullptr, q, stats);
}

Result<core::Image> CpuBackend::render_gradient(const PreparedTexton& tex, const NoiseRequest& q,
                                                int axis) {
    assert(!tex.check(q));
    if (q.level >= tex.limit_level() || tex.order() == 0 || (axis != 0 && axis != 1))
        return make_error(ErrorCode::unsupported,
                          "the exact gradient needs an exact level and order 1 or 3");
    const auto table = tex.table(q.level);
    return render_exact(tex, {table.get()}, nullptr, q, nullptr, axis);
}

Result<core::Image> CpuBackend::render_mix(const PreparedMix& mix, const NoiseRequest& q,
                                           RenderStats* stats) {
    assert(!mix.check(q));
    const PreparedTexton& first = mix.level(0);
    if (q.level >= first.limit_level()) {
        core::Image out(q.width, q.height, mix.channels());
        if (!render_limit_mix(mix, q, m_threads, out)) return abandoned(q.cancel, "the render");
        if (stats) {
            stats->limit_model = true;
            stats->points = 0;
            stats->evaluations = static_cast<std::uint64_t>(q.width) * q.height * 25;
        }
        return out;
    }
    const auto keep = mix.tables(q.level);
    std::vector<const LevelTable*> tables;
    for (const auto& t : *keep) tables.push_back(t.get());
    return render_exact(first, tables, &mix, q, stats);
}

Result<core::Image> CpuBackend::render_exact(const PreparedTexton& tex,
                                             const std::vector<const LevelTable*>& tables,
                                             const PreparedMix* mix, const NoiseRequest& q,
                                             RenderStats* stats, int deriv) {
    core::Image out = take_image(q.width, q.height, tex.channels()); // every pixel is written
    const LevelTable* table = tables.front();
    const GridPoisson grid(tex.size(), q.mni, q.period);
    LevelGeometry geo;
    geo.level = q.level;
    geo.st = q.level > 0 ? std::int64_t{1} << q.level : 1;
    geo.sub = q.level < 0 ? std::int64_t{1} << -q.level : 1;
    geo.length = table->length;
    geo.order = tex.order();
    geo.reach = tex.order() == 3 ? 1 : 0;
    geo.deriv = deriv;

    const int bs = m_block;
    const int nbx = (q.width + bs - 1) / bs, nby = (q.height + bs - 1) / bs;
    std::atomic<std::uint64_t> points{0}, evaluations{0};
    std::atomic<bool> skipped{false};
#pragma omp parallel for schedule(dynamic) num_threads(m_threads)
    for (int b = 0; b < nbx * nby; ++b) {
        if (stopped(q.cancel)) {
            skipped = true;
            continue;
        }
        const int bx = b % nbx, by = b / nbx;
        Block blk{q.x0 + static_cast<std::int64_t>(bx) * bs,
                  q.y0 + static_cast<std::int64_t>(by) * bs, std::min(bs, q.width - bx * bs),
                  std::min(bs, q.height - by * bs)};
        std::uint64_t p = 0, e = 0;
        render_block(tex, tables, mix, grid, geo, q, blk, out, p, e);
        points += p;
        evaluations += e;
    }
    if (stats) { // also when abandoned: what was done before it stopped
        stats->limit_model = false;
        stats->points = points;
        stats->evaluations = evaluations;
    }
    if (skipped) return abandoned(q.cancel, "the render");
    return out;
}

} // namespace textond::render
