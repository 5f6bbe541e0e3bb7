#pragma once
// The texture-mix workflow without HTTP (texton-noise section 7): both textons must be stored;
// a mix stored already is answered at once; any other runs on the analysis pool (single flight
// per id, like a texton), which re-reads both exemplars, takes their common models and the R
// optimal-transport barycentres, and stores the levels. The levels do not depend on the field:
// a mix of a pair, level count and grid that this process stored already lends its levels to
// every other field of them (a ramp turned, another mask), which is stored without analysis.
#include "api/mix_meta.h"
#include "api/requests.h"
#include "core/result.h"
#include "server/app/analysis_pool.h"
#include "server/io/mix_file.h"
#include "server/store/mix_store.h"
#include "server/store/texton_store.h"

#include <array>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

namespace textond::app {

class MixService {
public:
    MixService(store::TextonStore& textons, store::MixStore& mixes, AnalysisPool& pool);

    // The stored form of a mix of m.u and m.v with u's analysis parameters (`mu`), on `grid`,
    // the grid its id names (from the textons' metadata): exemplars that decode to another size
    // are a storage error, never a mix stored under an id it does not hash to.
    // With `sibling` (a stored mix whose levels are the ones this analysis would make: the same
    // u, v, levels, grid and parameters, checked by the caller), its levels, moved out of it,
    // instead of an analysis.
    static Result<io::MixRecord> analyse(store::TextonStore& textons, const api::MixRequest& m,
                                         const api::TextonMeta& mu, const std::string& id,
                                         const std::array<int, 2>& grid,
                                         io::MixRecord* sibling = nullptr);

    struct Started {
        std::string id;
        std::optional<api::MixMeta> known; // stored already: nothing was submitted
        bool refused = false;              // `admit` said no: nothing was submitted
        AnalysisPool::Submitted submitted; // otherwise the job; a null job: the queue is full
    };
    // not_found (or unavailable) when a texton is not stored. A mix not stored yet is submitted
    // only if `admit` takes its estimated CPU seconds (work_cost.h, mix_work_s).
    Result<Started> start(const api::MixRequest& m, const std::function<bool(double)>& admit);

    // Mixes stored here by levels key (u, v, levels, grid): one id each, at most kSiblings.
    class Siblings {
    public:
        static std::string key(const api::MixRequest& m, const std::array<int, 2>& grid);
        std::optional<std::string> find(const std::string& key) const;
        void remember(const std::string& key, const std::string& id);

    private:
        static constexpr std::size_t kSiblings = 4096;
        mutable std::mutex m_mutex;
        std::unordered_map<std::string, std::string> m_ids;
    };

private:
    store::TextonStore& m_textons;
    store::MixStore& m_mixes;
    AnalysisPool& m_pool;
    // Shared with the jobs, which may outlive a call of start().
    std::shared_ptr<Siblings> m_siblings = std::make_shared<Siblings>();
};

} // namespace textond::app
