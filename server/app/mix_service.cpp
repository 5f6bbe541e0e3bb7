#include "server/app/mix_service.h"

#include "core/texture_mix.h"
#include "server/app/work_cost.h"
#include "server/io/image_io.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>

namespace textond::app {

MixService::MixService(store::TextonStore& textons, store::MixStore& mixes, AnalysisPool& pool)
    : m_textons(textons), m_mixes(mixes), m_pool(pool) {}

std::string MixService::Siblings::key(const api::MixRequest& m, const std::array<int, 2>& grid) {
    return m.u + "/" + m.v + "/" + std::to_string(m.levels) + "/" + std::to_string(grid[0]) + "x" +
           std::to_string(grid[1]);
}

std::optional<std::string> MixService::Siblings::find(const std::string& key) const {
    std::lock_guard lock(m_mutex);
    auto it = m_ids.find(key);
    if (it == m_ids.end()) return std::nullopt;
    return it->second;
}

void MixService::Siblings::remember(const std::string& key, const std::string& id) {
    std::lock_guard lock(m_mutex);
    if (m_ids.size() >= kSiblings && m_ids.count(key) == 0) m_ids.erase(m_ids.begin());
    m_ids[key] = id;
}

namespace {
// Whether a stored mix's levels are the ones an analysis of `m` on `grid` with parameters `p`
// would make: the same textons, level count, grid, mix version and analysis parameters (the
// texton ids name their parameters; checked again, as a file on disk may say otherwise).
bool same_levels(const api::MixMeta& s, const api::MixRequest& m, const std::array<int, 2>& grid,
                 const core::AnalysisParams& p) {
    return s.version == core::kMixVersion && s.u == m.u && s.v == m.v && s.levels == m.levels &&
           s.grid == grid && s.size == p.size && s.order == p.order &&
           s.iterations == p.iterations && s.seed == p.seed && s.periodic == p.periodic;
}
} // namespace

Result<io::MixRecord> MixService::analyse(store::TextonStore& textons, const api::MixRequest& m,
                                          const api::TextonMeta& mu, const std::string& id,
                                          const std::array<int, 2>& grid, io::MixRecord* sibling) {
    const auto t0 = std::chrono::steady_clock::now();
    const core::AnalysisParams p = mu.params();
    io::MixRecord record;
    std::vector<double> rme;
    std::array<int, 2> made_grid = grid;
    if (sibling != nullptr) {
        record.levels = std::move(sibling->levels);
        rme = sibling->meta.rme;
    } else {
        auto eu = textons.exemplar_image(m.u);
        if (!eu) return eu.error();
        auto ev = textons.exemplar_image(m.v);
        if (!ev) return ev.error();
        if (core::mix_grid(eu.value().width, eu.value().height, ev.value().width, ev.value().height,
                           2 * p.size) != grid)
            return make_error(ErrorCode::io, "the stored exemplars of " + m.u + " and " + m.v +
                                                 " disagree in size with their textons' metadata");
        auto pair = core::common_models(eu.value(), ev.value(), p.periodic, p.threads, 2 * p.size);
        if (!pair) return pair.error();
        auto levels = core::mix_levels(pair.value(), p, m.levels);
        if (!levels) return levels.error();
        record.levels = std::move(levels.value().levels);
        rme = levels.value().rme;
        made_grid = {pair.value().u.width, pair.value().u.height};
    }
    record.field = m.field;
    api::MixMeta& meta = record.meta;
    meta.id = id;
    meta.version = core::kMixVersion;
    meta.u = m.u;
    meta.v = m.v;
    meta.levels = m.levels;
    meta.size = p.size;
    meta.order = p.order;
    meta.channels = record.levels.front().channels;
    meta.iterations = p.iterations;
    meta.seed = p.seed;
    meta.periodic = p.periodic;
    meta.grid = made_grid;
    for (const auto& t : record.levels)
        meta.means.emplace_back(t.mean.begin(), t.mean.begin() + t.channels);
    meta.rme = std::move(rme);
    meta.field = io::field_json(m.field);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    meta.analysis_ms = ms;
    meta.created = api::rfc3339_now();
    return record;
}

Result<MixService::Started> MixService::start(const api::MixRequest& m,
                                              const std::function<bool(double)>& admit) {
    auto u = m_textons.find(m.u);
    if (!u) return u.error();
    auto v = m_textons.find(m.v);
    if (!v) return v.error();
    Started out;
    const api::TextonMeta &a = u.value(), &b = v.value();
    const auto grid = core::mix_grid(a.exemplar_width, a.exemplar_height, b.exemplar_width,
                                     b.exemplar_height, 2 * a.size);
    const bool cropped = grid != std::array<int, 2>{std::min(a.exemplar_width, b.exemplar_width),
                                                    std::min(a.exemplar_height, b.exemplar_height)};
    out.id = io::mix_id(m.u, m.v, m.levels, m.field,
                        cropped ? std::optional<std::array<int, 2>>(grid) : std::nullopt);
    // contains() asks the shared store now whether a copy held here was deleted elsewhere: a
    // creation after a delete stores the mix again (it answered 200 and stored nothing).
    if (m_mixes.contains(out.id))
        if (auto meta = m_mixes.meta(out.id)) {
            out.known = std::move(meta.value());
            return out;
        }
    if (!admit(mix_work_s(grid[0], grid[1], std::max(a.channels, b.channels), a.iterations,
                          m.levels))) {
        out.refused = true;
        return out;
    }
    // A mix is R texton analyses: it runs on the analysis pool, single flight per id, and a
    // full pool answers 429 at once (it waited on a mutex before: 15 s became 159 s).
    store::TextonStore* textons = &m_textons;
    store::MixStore* mixes = &m_mixes;
    const api::TextonMeta& mu = u.value(); // copied into the job by its capture
    const std::string id = out.id;
    out.submitted = m_pool.submit(
        "mix:" + id,
        [textons, mixes, siblings = m_siblings, m, mu, id,
         grid](const core::ProgressFn&) -> Result<AnalysisOutcome> {
            if (mixes->contains(id)) return AnalysisOutcome{mu, false};
            const std::string key = Siblings::key(m, grid);
            // A sibling deleted since, or unreadable, is no loss: the analysis runs.
            std::optional<io::MixRecord> sibling;
            if (auto sid = siblings->find(key); sid && *sid != id)
                if (auto r = mixes->levels(*sid); r && r.value().levels_verified &&
                                                  same_levels(r.value().meta, m, grid, mu.params()))
                    sibling = std::move(r.value());
            auto record = analyse(*textons, m, mu, id, grid, sibling ? &*sibling : nullptr);
            if (!record) return record.error();
            auto put = mixes->put(record.value());
            if (!put) return put.error();
            siblings->remember(key, id);
            spdlog::info("mixed {}: {} -> {}, {} levels, {:.0f} ms{}", id, m.u.substr(0, 12),
                         m.v.substr(0, 12), m.levels, record.value().meta.analysis_ms.value_or(0),
                         sibling ? ", the levels of " + sibling->meta.id : std::string());
            return AnalysisOutcome{mu, put.value()};
        });
    return out;
}

} // namespace textond::app
