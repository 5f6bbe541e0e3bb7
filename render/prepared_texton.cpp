#include "render/prepared_texton.h"

#include "core/grid_poisson.h"
#include "core/material_set.h"
#include "render/table_budget.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>

namespace textond::render {

using core::noise::kMaxLevel;
using core::noise::kMinLevel;

Result<std::shared_ptr<const PreparedTexton>> PreparedTexton::make(core::Texton t) {
    if (t.size < 8 || t.size > 256)
        return make_error(ErrorCode::invalid_argument,
                          "texton size " + std::to_string(t.size) + " outside [8, 256]");
    if (t.channels < 1 || t.channels > core::kMaxChannels)
        return make_error(ErrorCode::invalid_argument, "texton must have 1 to " +
                                                           std::to_string(core::kMaxChannels) +
                                                           " channels");
    if (t.maps.empty() && t.channels != 1 && t.channels != 3)
        return make_error(ErrorCode::invalid_argument, "texton must have 1 or 3 channels");
    if (!t.maps.empty())
        if (auto err = core::validate_maps(t.maps, t.channels)) return *err;
    if (t.order != 0 && t.order != 1 && t.order != 3)
        return make_error(ErrorCode::invalid_argument,
                          "interpolation order " + std::to_string(t.order) + " is not 0, 1 or 3");
    if (t.alpha.width != t.size || t.alpha.height != t.size || t.alpha.channels != t.channels)
        return make_error(ErrorCode::invalid_argument, "texton coefficients have the wrong shape");
    for (float v : t.alpha.data)
        if (!std::isfinite(v))
            return make_error(ErrorCode::unprocessable, "texton coefficients are not finite");
    return std::shared_ptr<const PreparedTexton>(new PreparedTexton(std::move(t)));
}

Result<std::shared_ptr<const PreparedTexton>>
PreparedTexton::make_map(const std::shared_ptr<const PreparedTexton>& set,
                         const std::string& name) {
    const core::Texton& s = set->texton();
    const core::TextonMap* m = core::find_map(s.maps, name);
    if (!m) return make_error(ErrorCode::not_found, "this texton has no map '" + name + "'");
    core::Texton t;
    t.size = s.size;
    t.order = s.order;
    t.channels = m->channels;
    for (int c = 0; c < m->channels; ++c)
        t.mean[static_cast<std::size_t>(c)] = s.mean[static_cast<std::size_t>(m->first + c)];
    t.alpha = core::channel_planes(s.alpha, m->first, m->channels);
    if (auto checked = make(t); !checked) return checked.error();
    std::shared_ptr<PreparedTexton> view(new PreparedTexton(std::move(t)));
    view->m_set = set;
    view->m_first = m->first;
    return std::shared_ptr<const PreparedTexton>(std::move(view));
}

Result<std::shared_ptr<const PreparedTexton>> PreparedTexton::map(const std::string& name) const {
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        if (auto it = m_maps.find(name); it != m_maps.end()) return it->second;
    }
    // The views own the joint model's holder, a copy of this set without views: were it the set
    // itself, set and views would own each other and never be freed.
    std::shared_ptr<const PreparedTexton> joint;
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        joint = m_joint;
    }
    if (!joint) {
        auto made = make(m_texton);
        if (!made) return made.error();
        std::lock_guard<std::mutex> lock(m_mutex);
        if (!m_joint) m_joint = made.value();
        joint = m_joint;
    }
    auto view = make_map(joint, name);
    if (!view) return view.error();
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_maps.emplace(name, view.value()).first->second;
}

PreparedTexton::PreparedTexton(core::Texton t)
    : m_texton(std::move(t)), m_cell_size(core::noise::cell_size(m_texton.size)),
      m_limit_level(core::noise::limit_level(m_texton.size)) {}

std::optional<Error> PreparedTexton::check(const NoiseRequest& q) const {
    auto bad = [](std::string m) { return make_error(ErrorCode::invalid_argument, std::move(m)); };
    if (!(q.mni >= core::noise::kMinMni && q.mni <= core::noise::kMaxMni))
        return bad("mni must be in [1, 200]");
    if (q.level < kMinLevel || q.level > kMaxLevel)
        return bad("level must be in [" + std::to_string(kMinLevel) + ", " +
                   std::to_string(kMaxLevel) + "]");
    if (q.width < 1 || q.height < 1 || q.width > kMaxWindowSide || q.height > kMaxWindowSide)
        return bad("window sides must be in [1, " + std::to_string(kMaxWindowSide) + "]");
    if (static_cast<std::int64_t>(q.width) * q.height > kMaxWindowPixels)
        return bad("window has more than " + std::to_string(kMaxWindowPixels) + " pixels");
    const std::int64_t bound = kPlaneHalfWidth >> std::max(0, q.level);
    auto inside = [&](std::int64_t v, int n) { return v >= -bound && v <= bound - n; };
    if (!inside(q.x0, q.width) || !inside(q.y0, q.height))
        return bad("window outside the plane: |x|, |y| must stay within 2^62 texels (" +
                   std::to_string(bound) + " pixels at level " + std::to_string(q.level) + ")");
    // The true reason: a material set keeps none (its analysis makes the joint Gaussian model
    // alone), and a texton of one exemplar has them from the version that began keeping them.
    if (q.marginals == Marginals::exemplar && m_texton.marginals.empty())
        return bad(m_set || !m_texton.maps.empty()
                       ? "marginals=exemplar is for textons of one exemplar: a material set's "
                         "maps are analysed as one joint Gaussian model, without exemplar "
                         "marginals; use marginals=gaussian"
                       : "marginals=exemplar needs the exemplar's marginals, which this texton "
                         "does not keep (analysed before they were kept); use "
                         "marginals=gaussian");
    const bool tileable = q.period[0] != 0 || q.period[1] != 0;
    if (tileable) {
        if (q.period[0] < 1 || q.period[1] < 1 || q.period[0] > (1 << 20) ||
            q.period[1] > (1 << 20))
            return bad("tileable period must be 1 to 2^20 cells on both axes");
        if (q.level >= m_limit_level)
            return bad("tileable mode is defined up to level " + std::to_string(m_limit_level - 1) +
                       " for this texton");
    }
    return std::nullopt;
}

namespace {

// LevelTable::phase_row's planes from the table's rows.
void split_by_phase(LevelTable& t, int st) {
    t.st = st;
    const int side = t.side();
    const int per = (side + st - 1) / st; // entries of one phase along an axis
    t.phase_rows = per + 1;
    t.phase_stride = (static_cast<std::size_t>(per) + 16 + 15) / 16 * 16;
    const std::size_t plane = static_cast<std::size_t>(t.phase_rows) * t.phase_stride;
    t.phase_data.assign(static_cast<std::size_t>(t.channels) * st * st * plane, 0.0f);
    for (int c = 0; c < t.channels; ++c)
        for (int y = 0; y < side; ++y)
            for (int x = 0; x < side; ++x)
                t.phase_data[t.phase_offset(c, y % st, x % st, y / st) +
                             static_cast<std::size_t>(x / st)] = t.row(c, y)[x];
}

} // namespace

std::size_t level_table_bytes(const LevelTable& t) {
    return (t.data.capacity() + t.phase_data.capacity()) * sizeof(float);
}

std::shared_ptr<const LevelTable> PreparedTexton::table(int level) const {
    auto t = derived_table(level);
    TableBudget::instance().use(t, level_table_bytes(*t));
    return t;
}

// Built under the texton's lock, once: concurrent tiles of a new level wait for the one build
// (each had built its own copy, 16 x 30 MB at once for a viewport).
std::shared_ptr<const LevelTable> PreparedTexton::derived_table(int level) const {
    const int key = std::max(0, level); // every magnification level uses alpha itself
    std::lock_guard<std::mutex> lock(m_mutex);
    auto& kept = m_tables[key];
    if (auto t = kept.lock()) return t;
    auto t = build_table(key);
    kept = t;
    return t;
}

std::shared_ptr<const LevelTable> PreparedTexton::build_table(int key) const {
    static std::atomic<std::uint64_t> serials{0};
    const int st = 1 << key;
    const core::Image g =
        key == 0 ? m_texton.alpha : core::noise::box_filtered_coefficients(m_texton.alpha, st);
    auto t = std::make_shared<LevelTable>();
    t->serial = ++serials;
    t->level = key;
    t->length = g.width;
    t->pad = table_pad(m_texton.order);
    t->channels = g.channels;
    // 16 zero floats of slack after every row: the CPU backend runs whole vectors past the end.
    t->stride = (static_cast<std::size_t>(t->side()) + 16 + 15) / 16 * 16;
    t->data.assign(static_cast<std::size_t>(g.channels) * t->side() * t->stride, 0.0f);
    for (int c = 0; c < g.channels; ++c)
        for (int y = 0; y < g.height; ++y) {
            float* dst = t->row(c, y + t->pad) + t->pad;
            for (int x = 0; x < g.width; ++x) dst[x] = g.at(c, x, y);
        }
    if (key >= 1 && m_texton.order <= 1) split_by_phase(*t, st);
    return t;
}

std::shared_ptr<const core::LagCovariance> PreparedTexton::covariance() const {
    std::shared_ptr<const core::LagCovariance> c;
    {
        std::lock_guard<std::mutex> lock(m_mutex); // made once, as a table is
        c = m_cov.lock();
        if (!c) {
            c = std::make_shared<const core::LagCovariance>(core::sampled_covariance(m_texton));
            m_cov = c;
        }
    }
    const auto n = static_cast<std::size_t>(2 * c->radius() + 1);
    const auto k = static_cast<std::size_t>(c->channels());
    TableBudget::instance().use(c, n * n * k * k * sizeof(double));
    return c;
}

std::shared_ptr<const core::MarginalTables> PreparedTexton::marginals(int level) const {
    if (m_texton.marginals.empty()) return nullptr;
    const int key = std::max(0, level);
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        if (auto it = m_marginals.find(key); it != m_marginals.end()) return it->second;
    }
    // The level's variance along each principal direction of the exemplar's colours: the box
    // average of 2^key texels (NOISE_SPEC.md section 6), whose tables keep level 0's mean.
    const core::ColourMatrix c =
        core::box_average_covariance(*covariance(), std::int64_t{1} << key, 0, 0);
    const core::MarginalModel& m = m_texton.marginals;
    std::array<double, 3> variance{};
    for (int i = 0; i < m.channels; ++i)
        for (int a = 0; a < m.channels; ++a)
            for (int b = 0; b < m.channels; ++b)
                variance[static_cast<std::size_t>(i)] += m.basis(a, i) * c(a, b) * m.basis(b, i);
    auto tables = std::make_shared<const core::MarginalTables>(m, variance);
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_marginals.emplace(key, std::move(tables)).first->second;
}

void restore_marginals(const core::MarginalTables& tables, core::Image& image) {
    const int nc = tables.channels();
    float v[3];
    for (std::size_t k = 0; k < image.plane_size(); ++k) {
        for (int c = 0; c < nc; ++c) v[c] = image.plane(c)[k];
        tables.apply(v);
        for (int c = 0; c < nc; ++c) image.plane(c)[k] = v[c];
    }
}

const core::noise::LimitModel& PreparedTexton::limit(int level) const {
    if (m_set) {
        core::noise::LimitModel joint = m_set->limit(level);
        joint.first = m_first;
        std::lock_guard<std::mutex> lock(m_mutex);
        return m_limits.emplace(level, joint).first->second;
    }
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        if (auto it = m_limits.find(level); it != m_limits.end()) return it->second;
    }
    const auto cov = covariance();
    core::noise::LimitModel model = core::noise::limit_model(*cov, std::int64_t{1} << level);
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_limits.emplace(level, model).first->second;
}

Result<std::shared_ptr<const PreparedTexton>>
map_view(Result<std::shared_ptr<const PreparedTexton>> prepared, const std::string& map) {
    if (!prepared) return prepared;
    const auto& maps = prepared.value()->texton().maps;
    if (maps.empty()) {
        if (map.empty()) return prepared;
        return make_error(ErrorCode::invalid_argument,
                          "map=" + map + " needs a material set; this texton has one exemplar");
    }
    const bool normals = map == core::kNormalMap || map == core::kLitMap;
    std::string name = normals ? core::kHeightMap : map;
    if (name.empty()) name = core::find_map(maps, "albedo") ? "albedo" : maps.front().name;
    auto view = prepared.value()->map(name);
    if (!view && view.error().code == ErrorCode::not_found)
        return make_error(ErrorCode::invalid_argument,
                          normals ? "map=normal and map=lit need the set's height map, which it "
                                    "does not have"
                                  : "this material set has no map '" + name + "'");
    return view;
}

} // namespace textond::render
