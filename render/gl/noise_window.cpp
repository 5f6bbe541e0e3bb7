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

namespace {

// The seed's two words and the base cell's x, as the shader's hash and cell loop take them.
void write_seed(Record& rec, std::uint64_t seed, std::int64_t base_x) {
    const auto seed_lo = static_cast<std::uint32_t>(seed);
    const auto seed_hi = static_cast<std::uint32_t>(seed >> 32);
    rec.u(slot::seed, seed_lo, seed_hi, lo(base_x), hi(base_x));
}

// The mean (grey repeats its channel) and the noise's scale 1 / sqrt(lambda).
void write_mean(Record& rec, const PreparedTexton& tex, double scale) {
    const auto& mean = tex.texton().mean;
    const bool grey = tex.channels() != 3;
    rec.f(slot::mean, mean[0], grey ? mean[0] : mean[1], grey ? mean[0] : mean[2], scale);
}

// The limit model's record (its kappa weights and colour matrix): no cells, no points.
void write_limit(Record& rec, const PreparedTexton& tex, const NoiseRequest& q) {
    const int nc = tex.channels();
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
    write_seed(rec, q.seed, 0); // no base cell: lo(0) = hi(0) = 0
    write_mean(rec, tex, 0.0);  // the limit model has no scale
    rec.u(slot::base_y, 0, 0, lo(q0x), hi(q0x));
    rec.u(slot::thresholds, lo(q0y), hi(q0y), 0, 0);
}

// The window's cells, counted from the base cell (bcx, bcy), and how many there are.
struct Cells {
    std::int64_t bcx = 0, bcy = 0, ncx = 0, ncy = 0;
};

// The window's points listed once: rows of cells (in parallel only for a frame's many rows: a
// tile's few are cheaper on the caller's thread than waking a team), then one run: cells by y
// then x, points in draw order, each point's mix layer in its top byte.
void list_points(NoiseWindow& win, const core::noise::GridPoisson& grid, const PreparedMix* mix,
                 std::uint64_t seed, const Cells& c) {
    const int a = grid.a;
    std::vector<std::vector<std::uint32_t>> rows(static_cast<std::size_t>(c.ncy));
    std::vector<std::uint32_t> counts(static_cast<std::size_t>(c.ncx * c.ncy));
#pragma omp parallel for schedule(dynamic) if (c.ncx * c.ncy > 4096)
    for (std::int64_t cy = 0; cy < c.ncy; ++cy) {
        std::vector<core::noise::CellPoint> pts;
        auto& row = rows[static_cast<std::size_t>(cy)];
        for (std::int64_t cx = 0; cx < c.ncx; ++cx) {
            const int n = grid.cell_points(seed, c.bcx + cx, c.bcy + cy, pts);
            counts[static_cast<std::size_t>(cy * c.ncx + cx)] = static_cast<std::uint32_t>(n);
        }
        row.reserve(pts.size() * 4);
        for (const auto& p : pts) {
            const int layer = mix ? mix->level_at(static_cast<double>(p.bx) + p.fx / 16777216.0,
                                                  static_cast<double>(p.by) + p.fy / 16777216.0)
                                  : 0;
            row.push_back(static_cast<std::uint32_t>(p.bx - c.bcx * a));
            row.push_back(static_cast<std::uint32_t>(p.by - c.bcy * a));
            row.push_back(p.fx | (p.eps < 0 ? 0x80000000u : 0u));
            row.push_back(p.fy | (static_cast<std::uint32_t>(layer) << 24));
        }
    }
    win.starts.assign(counts.size() + 1, 0);
    for (std::size_t i = 0; i < counts.size(); ++i) win.starts[i + 1] = win.starts[i] + counts[i];
    win.points.reserve(static_cast<std::size_t>(win.starts.back()) * 4);
    for (const auto& row : rows) win.points.insert(win.points.end(), row.begin(), row.end());
}

// A mix: all level tables as one array, and the field as an affine map (or a mask) of the
// position relative to the base cell's origin (NOISE_SPEC.md section 9).
void write_mix(NoiseWindow& win, Record& rec, const PreparedMix& mix, const LevelTable& table,
               int level, double bx, double by) {
    const int side = table.side(), nl = mix.levels();
    const std::size_t layer = static_cast<std::size_t>(side) * side * 4;
    win.mix_tables.assign(layer * static_cast<std::size_t>(nl), 0.0f);
    const auto tables = mix.tables(level);
    for (int l = 0; l < nl; ++l)
        interleave_table(*(*tables)[static_cast<std::size_t>(l)], 4,
                         win.mix_tables.data() + layer * static_cast<std::size_t>(l));
    const core::MixField& f = mix.field();
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
    const auto& mu = mix.level(0).texton().mean;
    const auto& mv = mix.level(nl - 1).texton().mean;
    const bool grey = win.channels == 1;
    rec.f(slot::mean_u, mu[0], grey ? mu[0] : mu[1], grey ? mu[0] : mu[2], 0);
    rec.f(slot::mean_v, mv[0], grey ? mv[0] : mv[1], grey ? mv[0] : mv[2], 0);
}

} // namespace

NoiseWindow make_noise_window(const PreparedTexton& tex, const PreparedMix* mix,
                              const NoiseRequest& q, bool host_lists) {
    NoiseWindow win;
    win.width = q.width;
    win.height = q.height;
    win.channels = tex.channels();
    win.precision = q.precision;
    win.bytes = q.bytes && q.precision == Precision::u8;
    win.cancel = q.cancel;
    Record rec{win.record};
    win.limit_model = q.level >= tex.limit_level();
    rec.i(slot::size, 0, 0, 0, tex.channels());
    if (win.limit_model) {
        write_limit(rec, tex, q);
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
    Cells cells;
    int ox, oy;
    base(q.x0, cells.bcx, ox);
    base(q.y0, cells.bcy, oy);
    const bool tileable = q.period[0] > 0;
    rec.i(slot::mode, 0, q.level, st, sub_log2);
    rec.i(slot::geometry, table->length, r, tex.order(), a);
    write_seed(rec, q.seed, cells.bcx);
    rec.u(slot::base_y, lo(cells.bcy), hi(cells.bcy), 0, 0);
    rec.i(slot::thresholds, 0, 0, static_cast<std::int64_t>(grid.thresholds.size()), 0);
    rec.i(slot::period, tileable ? q.period[0] : 0, tileable ? q.period[1] : 0,
          tileable ? floor_mod(cells.bcx, q.period[0]) : 0,
          tileable ? floor_mod(cells.bcy, q.period[1]) : 0);
    rec.i(slot::origin, ox, oy, 0, 0);
    write_mean(rec, tex, 1.0 / std::sqrt(grid.lambda));
    win.thresholds = grid.thresholds;

    // The window's cells from the base cell: up to the last pixel's reach (the shader's
    // reach_cells, in the same integers).
    auto last_cell = [&](int origin, int n) -> std::int64_t {
        if (q.level >= 0) return (origin + std::int64_t{n - 1} * st + st - 1 + reach) / a;
        return (((origin + std::int64_t{n - 1}) >> sub_log2) + 1 + reach) / a;
    };
    cells.ncx = last_cell(ox, q.width) + 1;
    cells.ncy = last_cell(oy, q.height) + 1;
    // Listing the window's points pays while there are far fewer of them than pixels (levels
    // <= 1); above, each pixel regenerates its own.
    const bool listed =
        host_lists && static_cast<double>(cells.ncx) * static_cast<double>(cells.ncy) * grid.mu <=
                          std::max(65536.0, static_cast<double>(q.width) * q.height / 8);
    rec.i(slot::table, table->side(), 0, listed ? 1 : 0, 0);
    rec.i(slot::cells, listed ? cells.ncx : 0, listed ? cells.ncy : 0, 0, mix ? 1 : 0);
    if (listed) list_points(win, grid, mix, q.seed, cells);
    if (!mix) {
        win.table = table;
        return win;
    }
    write_mix(win, rec, *mix, *table, q.level, static_cast<double>(cells.bcx) * a,
              static_cast<double>(cells.bcy) * a);
    return win;
}

} // namespace textond::render::gl
