#pragma once
// The texton ingest workflow without HTTP: exemplar bytes are decoded (under a decoder slot),
// checked against the parameters and content-addressed; a texton stored already (here or in the
// shared store) is answered at once, any other is analysed on the pool and stored. The upload
// route only reads the body and turns the outcome into a response; `textond analyze` runs the
// same analyse() step, so both write the same texton file for the same exemplar and parameters.
#include "api/texton_meta.h"
#include "core/image.h"
#include "core/result.h"
#include "core/texton_analysis.h"
#include "server/app/analysis_pool.h"
#include "server/app/metrics.h"
#include "server/app/slots.h"
#include "server/app/work_cost.h"
#include "server/io/image_io.h"
#include "server/io/texton_file.h"
#include "server/store/texton_store.h"

#include <chrono>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

namespace textond::app {

class TextonService {
public:
    // `max_work_s`: the CPU an analysis may cost (analysis_work_s), 0 for no bound.
    TextonService(store::TextonStore& store, AnalysisPool& pool, Metrics& metrics,
                  WorkSlots& decode_slots, io::DecodeLimits limits,
                  std::chrono::milliseconds decode_wait, double max_work_s = 0);

    // Exemplar and parameters to the stored form of a texton: coefficients, RME, id, timings
    // (SOT paper section 3 through core::analyze_texton). What the pool runs for an upload and
    // what `textond analyze` runs.
    static Result<io::TextonRecord> analyse(const core::Image& exemplar,
                                            const core::AnalysisParams& params,
                                            const core::ProgressFn& progress);

    struct Ingested {
        std::string id;
        std::optional<api::TextonMeta> known; // stored already: nothing was submitted
        AnalysisPool::Submitted submitted;    // otherwise the job; a null job: the queue is full
    };
    struct Refused {
        enum class Stage {
            busy,   // no decoder slot freed in time (`admit` says why)
            decode, // the bytes are no image this service takes (error: too_large, unsupported,
                    // or any other for a corrupt file)
            check,  // the parameters do not fit the exemplar (too small for the support)
            lookup, // the store could not say whether the texton exists (shared store down)
            size,   // a material set's maps disagree in size, or have too many channels
            work,   // the analysis would cost more CPU than --max-request-cpu-s
        } stage;
        Error error;
        WorkSlots::Admit admit = WorkSlots::Admit::granted;
    };
    // `gone` tells the decoder-slot wait that the client left.
    std::variant<Ingested, Refused> ingest(std::string_view bytes,
                                           const core::AnalysisParams& params,
                                           const std::function<bool()>& gone = {});

    // A material set (core/material_set.h): one image per map, all of one size; albedo keeps RGB
    // (or grey), the other maps are grey (an RGB file's channels averaged). Stored as one texton.
    struct MapUpload {
        std::string name;
        std::string_view bytes;
    };
    std::variant<Ingested, Refused> ingest_set(const std::vector<MapUpload>& maps,
                                               const core::AnalysisParams& params,
                                               const std::function<bool()>& gone = {});
    static Result<io::TextonRecord> analyse_set(const core::Image& stacked,
                                                const std::vector<api::MapMeta>& maps,
                                                const core::AnalysisParams& params,
                                                const core::ProgressFn& progress);

private:
    // What a job makes once a worker takes it: the record, and `shown` (the exemplar, or a set's
    // first map) to store beside it.
    struct Analysed {
        io::TextonRecord record;
        core::Image shown;
    };
    using Analyse = std::function<Result<Analysed>(const core::ProgressFn&)>;
    // Runs `analyse` on the pool and stores what it made. A queued job holds its upload's encoded
    // bytes, never its decoded pixels: `analyse` decodes them again when a worker takes it, so
    // the decoded images in memory are those of the analyses running.
    // `work_s`: the analysis's estimate (for the "analysis" slow point).
    AnalysisPool::Submitted submit(const std::string& id, double work_s, const Analyse& analyse);
    // A set's maps decoded and stacked in canonical order (no decoder slot taken: the caller
    // holds one, or is a worker of the bounded pool).
    static std::optional<Refused> stack_maps(const std::vector<MapUpload>& maps,
                                             const io::DecodeLimits& limits, core::Image& stacked,
                                             std::vector<api::MapMeta>& meta);
    std::optional<Refused> store_refuses_writes() const;
    // The refusal of an analysis over the CPU bound, if it is.
    std::optional<Refused> over_budget(const core::Image& u, const core::AnalysisParams& p) const;
    std::optional<Refused> decode_maps(const std::vector<MapUpload>& maps, core::Image& stacked,
                                       std::vector<api::MapMeta>& meta,
                                       const std::function<bool()>& gone);

    store::TextonStore& m_store;
    AnalysisPool& m_pool;
    Metrics& m_metrics;
    WorkSlots& m_decode_slots;
    const io::DecodeLimits m_limits;
    const std::chrono::milliseconds m_decode_wait;
    const double m_max_work_s; // 0: no bound
};

} // namespace textond::app
