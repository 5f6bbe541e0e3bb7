#include "render/gl/noise_window.h"

#include "core/grid_poisson.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace textond::render::gl {

using core::noise::floor_div;
using core::noise::floor_mod;

namespace {

std::uint32_t word(float f) {
    std::uint32_t w;
    std::memcpy(&w, &f, 4);
    return w;
}

// The record's vec4 `slot`, as texton_noise.comp's load_tile reads it.
struct Record {
    std::array<std::uint32_t, kRecordWords>& w;
    void u(int slot, std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
        w[4 * slot] = a;
        w[4 * slot + 1] = b;
        w[4 * slot + 2] = c;
        w[4 * slot + 3] = d;
    }
    void i(int slot, std::int64_t a, std::int64_t b, std::int64_t c, std::int64_t d) {
        u(slot, static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b),
          static_cast<std::uint32_t>(c), static_cast<std::uint32_t>(d));
    }
    void f(int slot, double a, double b, double c, double d) {
        u(slot, word(static_cast<float>(a)), word(static_cast<float>(b)),
          word(static_cast<float>(c)), word(static_cast<float>(d)));
    }
};

std::uint32_t lo(std::int64_t v) {
    return static_cast<std::uint32_t>(static_cast<std::uint64_t>(v));
}
std::uint32_t hi(std::int64_t v) {
    return static_cast<std::uint32_t>(static_cast<std::uint64_t>(v) >> 32);
}

} // namespace

void interleave_table(const LevelTable& t, int components, float* out) {
    const int n = t.side();
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
            for (int c = 0; c < t.channels; ++c)
                out[(static_cast<std::size_t>(y) * n + x) * components + c] = t.row(c, y)[x];
}

NoiseWindow make_noise_window(const PreparedTexton& tex, const PreparedMix* mix,
                              const NoiseRequest& q, bool host_lists) {
    NoiseWindow win;
    win.width = q.width;
    win.height = q.height;
    win.channels = tex.channels();
    win.precision = q.precision;
    win.cancel = q.cancel;
    Record rec{win.record};
    const int nc = tex.channels();
    const bool limit = q.level >= tex.limit_level();
    win.limit_model = limit;
    const auto& mean = tex.texton().mean;
    // The mean (grey repeats its channel) and the noise's scale 1 / sqrt(lambda).
    auto mean_and_scale = [&](double scale) {
        rec.f(slot::mean, mean[0], nc == 3 ? mean[1] : mean[0], nc == 3 ? mean[2] : mean[0], scale);
    };
    const auto seed_lo = static_cast<std::uint32_t>(q.seed);
    const auto seed_hi = static_cast<std::uint32_t>(q.seed >> 32);
    rec.i(slot::size, 0, 0, 0, nc);
    if (limit) {
        const auto& lm = tex.limit(q.level);
        rec.i(slot::mode, 1, q.level, 0, 0);
        for (int s = 0; s < 7; ++s) {
            double k[4] = {0, 0, 0, 0};
            for (int j = 0; j < 4 && 4 * s + j < 25; ++j)
                k[j] = lm.kappa[static_cast<std::size_t>(4 * s + j)];
            rec.f(slot::kappa + s, k[0], k[1], k[2], k[3]);
        }
        for (int c = 0; c < 3; ++c) {
            double row[3] = {0, 0, 0};
            if (c < nc)
                for (int d = 0; d < nc; ++d) row[d] = lm.a(c, d);
            rec.f(slot::colour + c, row[0], row[1], row[2], 0.0);
        }
        const std::int64_t q0x = q.x0 - 2, q0y = q.y0 - 2;
        rec.u(slot::seed, seed_lo, seed_hi, 0, 0);
        mean_and_scale(0.0); // the limit model has no scale
        rec.u(slot::base_y, 0, 0, lo(q0x), hi(q0x));
        rec.u(slot::thresholds, lo(q0y), hi(q0y), 0, 0);
        return win;
    }

    const auto table = tex.table(q.level);
    const core::noise::GridPoisson grid(tex.size(), q.mni, q.period);
    const int r = tex.size(), a = grid.a;
    const std::int64_t st = q.level > 0 ? std::int64_t{1} << q.level : 1;
    const int sub_log2 = q.level < 0 ? -q.level : 0;
    // The base cell makes every relative cell and position in the shader non-negative.
    const int reach = tex.order() == 3 ? 1 : 0;
    auto base = [&](std::int64_t p0, std::int64_t& cell, int& origin) {
        if (q.level >= 0) {
            cell = floor_div(st * p0 - r - reach, a);
            origin = static_cast<int>(st * p0 - cell * a);
        } else {
            cell = floor_div(floor_div(p0, std::int64_t{1} << sub_log2) - r - 1 - reach, a);
            origin = static_cast<int>(p0 - (cell * a << sub_log2));
        }
    };
    std::int64_t bcx, bcy;
    int ox, oy;
    base(q.x0, bcx, ox);
    base(q.y0, bcy, oy);
    const bool tileable = q.period[0] > 0;
    rec.i(slot::mode, 0, q.level, st, sub_log2);
    rec.i(slot::geometry, table->length, r, tex.order(), a);
    rec.u(slot::seed, seed_lo, seed_hi, lo(bcx), hi(bcx));
    rec.u(slot::base_y, lo(bcy), hi(bcy), 0, 0);
    rec.i(slot::thresholds, 0, 0, static_cast<std::int64_t>(grid.thresholds.size()), 0);
    rec.i(slot::period, tileable ? q.period[0] : 0, tileable ? q.period[1] : 0,
          tileable ? floor_mod(bcx, q.period[0]) : 0, tileable ? floor_mod(bcy, q.period[1]) : 0);
    rec.i(slot::origin, ox, oy, 0, 0);
    mean_and_scale(1.0 / std::sqrt(grid.lambda));
    win.thresholds = grid.thresholds;

    // The window's cells from the base cell: up to the last pixel's reach (the shader's
    // reach_cells, in the same integers).
    auto last_cell = [&](int origin, int n) -> std::int64_t {
        if (q.level >= 0) return (origin + std::int64_t{n - 1} * st + st - 1 + reach) / a;
        return (((origin + std::int64_t{n - 1}) >> sub_log2) + 1 + reach) / a;
    };
    const std::int64_t ncx = last_cell(ox, q.width) + 1, ncy = last_cell(oy, q.height) + 1;
    // Listing the window's points pays while there are far fewer of them than pixels (levels
    // <= 1); above, each pixel regenerates its own.
    const bool listed =
        host_lists && static_cast<double>(ncx) * static_cast<double>(ncy) * grid.mu <=
                          std::max(65536.0, static_cast<double>(q.width) * q.height / 8);
    rec.i(slot::table, table->side(), 0, listed ? 1 : 0, 0);
    rec.i(slot::cells, listed ? ncx : 0, listed ? ncy : 0, 0, mix ? 1 : 0);
    if (listed) {
        // Rows of cells (in parallel only for a frame's many rows: a tile's few are cheaper on
        // the caller's thread than waking a team), then one run: cells by y then x, points in
        // draw order.
        std::vector<std::vector<std::uint32_t>> rows(static_cast<std::size_t>(ncy));
        std::vector<std::uint32_t> counts(static_cast<std::size_t>(ncx * ncy));
#pragma omp parallel for schedule(dynamic) if (ncx * ncy > 4096)
        for (std::int64_t cy = 0; cy < ncy; ++cy) {
            std::vector<core::noise::CellPoint> pts;
            auto& row = rows[static_cast<std::size_t>(cy)];
            for (std::int64_t cx = 0; cx < ncx; ++cx) {
                const int n = grid.cell_points(q.seed, bcx + cx, bcy + cy, pts);
                counts[static_cast<std::size_t>(cy * ncx + cx)] = static_cast<std::uint32_t>(n);
            }
            row.reserve(pts.size() * 4);
            for (const auto& p : pts) {
                const int layer = mix ? mix->level_at(static_cast<double>(p.bx) + p.fx / 16777216.0,
                                                      static_cast<double>(p.by) + p.fy / 16777216.0)
                                      : 0;
                row.push_back(static_cast<std::uint32_t>(p.bx - bcx * a));
                row.push_back(static_cast<std::uint32_t>(p.by - bcy * a));
                row.push_back(p.fx | (p.eps < 0 ? 0x80000000u : 0u));
                row.push_back(p.fy | (static_cast<std::uint32_t>(layer) << 24));
            }
        }
        win.starts.assign(counts.size() + 1, 0);
        for (std::size_t i = 0; i < counts.size(); ++i)
            win.starts[i + 1] = win.starts[i] + counts[i];
        win.points.reserve(static_cast<std::size_t>(win.starts.back()) * 4);
        for (const auto& row : rows) win.points.insert(win.points.end(), row.begin(), row.end());
    }
    if (!mix) {
        win.table = table;
        return win;
    }
    // All level tables as one array, and the field as an affine map (or a mask) of the position
    // relative to the base cell's origin (NOISE_SPEC.md section 9).
    const int side = table->side(), nl = mix->levels();
    const std::size_t layer = static_cast<std::size_t>(side) * side * 4;
    win.mix_tables.assign(layer * static_cast<std::size_t>(nl), 0.0f);
    for (int l = 0; l < nl; ++l)
        interleave_table(*mix->level(l).table(q.level), 4,
                         win.mix_tables.data() + layer * static_cast<std::size_t>(l));
    const core::MixField& f = mix->field();
    const double bx = static_cast<double>(bcx) * a, by = static_cast<double>(bcy) * a;
    if (f.kind == core::MixField::Kind::ramp) {
        const double n = std::hypot(f.dx, f.dy) * f.width;
        rec.f(slot::field, 0, f.dx / n, f.dy / n, ((bx - f.x0) * f.dx + (by - f.y0) * f.dy) / n);
        win.record[slot::field * 4] = 0; // the kind, an integer
        rec.f(slot::mask, 0, 0, 0, 0);
    } else {
        win.mask = &f;
        rec.f(slot::field, 0, 0, 0, 0);
        win.record[slot::field * 4] = 1;
        rec.f(slot::mask, 1.0 / f.scale, (bx - f.x0) / f.scale, (by - f.y0) / f.scale, 0);
    }
    win.record[slot::mask * 4 + 3] = static_cast<std::uint32_t>(nl);
    const auto& mu = mix->level(0).texton().mean;
    const auto& mv = mix->level(nl - 1).texton().mean;
    const bool grey = nc == 1;
    rec.f(slot::mean_u, mu[0], grey ? mu[0] : mu[1], grey ? mu[0] : mu[2], 0);
    rec.f(slot::mean_v, mv[0], grey ? mv[0] : mv[1], grey ? mv[0] : mv[2], 0);
    return win;
}

} // namespace textond::render::gl
