#pragma once
// A texton made ready for evaluation: validated once, with the per-level coefficient tables and
// limit models of NOISE_SPEC.md section 6 built on first use and shared by every backend and
// thread afterwards.
#include "core/noise_levels.h"
#include "core/result.h"
#include "core/texton.h"
#include "core/texton_covariance.h"
#include "render/noise_request.h"

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace textond::render {

// Coefficients of one level (alpha for k <= 0, g_k for k > 0), length L per side, stored with
// `pad` zeros on every side (1 for orders 0 and 1, 3 for order 3: NOISE_SPEC.md section 7):
// row(c, i)[j] = G[i][j] = g(i - pad, j - pad), i, j in [0, L + 2 pad).
struct LevelTable {
    std::uint64_t serial = 0; // unique to this table in the process: a cache's key
    int level = 0;
    int length = 0; // L
    int pad = 1;
    std::size_t stride = 0; // floats per row (>= L + 2 pad + 16 zeros, a multiple of 16)
    int channels = 0;
    std::vector<float> data;

    // Zoomed-out levels (k >= 1, orders 0 and 1): G split by phase, so that the texels one point
    // gives consecutive output pixels (st apart in G) are consecutive in memory:
    // phase_row(c, my, mx, j)[i] = G[st j + my][st i + mx], zeros past G and for 16+ floats
    // past every row. Empty otherwise.
    int st = 1;                   // texels per output pixel
    int phase_rows = 0;           // rows of one phase plane
    std::size_t phase_stride = 0; // floats per phase row
    std::vector<float> phase_data;
    std::size_t phase_channel_size() const {
        return static_cast<std::size_t>(st) * st * static_cast<std::size_t>(phase_rows) *
               phase_stride;
    }
    std::size_t phase_offset(int c, int my, int mx, int j) const {
        const std::size_t plane = static_cast<std::size_t>(phase_rows) * phase_stride;
        return ((static_cast<std::size_t>(c) * st + my) * st + mx) * plane +
               static_cast<std::size_t>(j) * phase_stride;
    }
    const float* phase_row(int c, int my, int mx, int j) const {
        return phase_data.data() + phase_offset(c, my, mx, j);
    }

    int side() const { return length + 2 * pad; }
    const float* row(int c, int i) const {
        return data.data() + (static_cast<std::size_t>(c) * side() + i) * stride;
    }
    float* row(int c, int i) {
        return data.data() + (static_cast<std::size_t>(c) * side() + i) * stride;
    }
};

// What a table holds, in bytes.
std::size_t level_table_bytes(const LevelTable& t);

// Zeros on each side of a level table for interpolation order `order`.
inline int table_pad(int order) {
    return order == 3 ? 3 : 1;
}

class PreparedTexton {
public:
    static Result<std::shared_ptr<const PreparedTexton>> make(core::Texton texton);
    // Map `name` of a material set (core/material_set.h) as a texton of its own channels, driven
    // by the set's Poisson process (the same seed gives aligned maps) and, at limit levels, by
    // the set's joint model (limit_coupled()). not_found for a name the set does not have.
    static Result<std::shared_ptr<const PreparedTexton>>
    make_map(const std::shared_ptr<const PreparedTexton>& set, const std::string& name);
    // The same, made once per name and kept with the set (so its level tables are too).
    Result<std::shared_ptr<const PreparedTexton>> map(const std::string& name) const;

    const core::Texton& texton() const { return m_texton; }
    int size() const { return m_texton.size; }
    int channels() const { return m_texton.channels; }
    int order() const { return m_texton.order; }
    int cell_size() const { return m_cell_size; }
    int limit_level() const { return m_limit_level; }
    // A map of a set: its limit model reads the set's normals (GL backends leave those levels
    // to the CPU).
    bool limit_coupled() const { return m_set != nullptr; }

    // Why `req` cannot be evaluated (a clear message), or nothing when it can.
    std::optional<Error> check(const NoiseRequest& req) const;

    // The level's table, kept by the table budget (render/table_budget.h).
    std::shared_ptr<const LevelTable> table(int level) const;
    // The same, made once while someone holds it, left out of the budget: for a holder that
    // budgets a group of tables as one (PreparedMix::tables).
    std::shared_ptr<const LevelTable> derived_table(int level) const;
    const core::noise::LimitModel& limit(int level) const;
    // Held by the caller while used: the table budget may let it go (render/table_budget.h).
    std::shared_ptr<const core::LagCovariance> covariance() const;
    // The exemplar's marginal tables at `level` (magnification uses level 0's), made once; null
    // when the texton keeps no marginals.
    std::shared_ptr<const core::MarginalTables> marginals(int level) const;

private:
    explicit PreparedTexton(core::Texton t);
    core::Texton m_texton;
    std::shared_ptr<const PreparedTexton> m_set; // the set's joint model (a copy without views)
    int m_first = 0;                             // the map's first channel in the set
    int m_cell_size = 0;
    int m_limit_level = 0;
    mutable std::mutex m_mutex;
    std::shared_ptr<const LevelTable> build_table(int key) const;
    // Kept by the process's table budget (render/table_budget.h), not here: a table past it is
    // built again when asked for.
    mutable std::map<int, std::weak_ptr<const LevelTable>> m_tables;
    mutable std::map<int, core::noise::LimitModel> m_limits;
    mutable std::weak_ptr<const core::LagCovariance> m_cov; // kept by the table budget
    mutable std::map<int, std::shared_ptr<const core::MarginalTables>> m_marginals;
    mutable std::map<std::string, std::shared_ptr<const PreparedTexton>> m_maps;
    mutable std::shared_ptr<const PreparedTexton> m_joint; // what the views share (map())
};

// The texton that shows `map` (api MapChoice names) of `prepared`: a set's map (its albedo, or its
// first map, for ""; the height for "normal" and "lit"), or a plain texton as it is for "";
// invalid_argument with the reason otherwise. Errors of `prepared` pass through.
Result<std::shared_ptr<const PreparedTexton>>
map_view(Result<std::shared_ptr<const PreparedTexton>> prepared, const std::string& map);

// Maps every pixel of `image` (a render of the texton `tables` belong to) onto the exemplar's
// marginals: pointwise, so windows and tiles of one plane still agree bit for bit.
void restore_marginals(const core::MarginalTables& tables, core::Image& image);

} // namespace textond::render
