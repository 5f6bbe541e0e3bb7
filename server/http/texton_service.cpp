#include "server/http/texton_service.h"

#include <spdlog/spdlog.h>

#include <memory>

namespace textond::http {

TextonService::TextonService(TextonStore& store, AnalysisPool& pool, Metrics& metrics,
                             RenderSlots& decode_slots, io::DecodeLimits limits,
                             std::chrono::milliseconds decode_wait)
    : m_store(store), m_pool(pool), m_metrics(metrics), m_decode_slots(decode_slots),
      m_limits(std::move(limits)), m_decode_wait(decode_wait) {}

Result<io::TextonRecord> TextonService::analyse(const core::Image& exemplar,
                                                const core::AnalysisParams& params,
                                                const core::ProgressFn& progress) {
    auto result = core::analyze_texton(exemplar, params, progress);
    if (!result) return result.error();
    return io::make_record(exemplar, params, result.value());
}

std::variant<TextonService::Ingested, TextonService::Refused>
TextonService::ingest(std::string_view bytes, const core::AnalysisParams& params,
                      const std::function<bool()>& gone) {
    using Stage = Refused::Stage;
    // Decoding takes up to 16 bytes a pixel: at most as many at once as there are slots.
    const auto admit = m_decode_slots.acquire(m_decode_wait, gone);
    if (admit != RenderSlots::Admit::granted)
        return Refused{Stage::busy, make_error(ErrorCode::unavailable, "no decoder"), admit};
    auto image = [&] {
        SlotGuard slot(&m_decode_slots);
        return io::decode_image_memory(bytes, m_limits);
    }();
    if (!image) return Refused{Stage::decode, image.error()};
    const core::Image& u = image.value();
    if (auto err = core::validate_analysis(params, u.width, u.height, u.channels))
        return Refused{Stage::check, *err};

    Ingested out;
    out.id = io::texton_id(u, params);
    // Known here or to another replica (shared store): no analysis. With the shared store down,
    // nothing could be stored, so fail now rather than after the analysis.
    if (auto meta = m_store.find(out.id)) {
        out.known = std::move(meta.value());
        return out;
    } else if (meta.error().code != ErrorCode::not_found) {
        return Refused{Stage::lookup, meta.error()};
    }
    out.submitted = submit(out.id, std::move(image.value()), params);
    return out;
}

AnalysisPool::Submitted TextonService::submit(const std::string& id, core::Image exemplar,
                                              const core::AnalysisParams& params) {
    auto u = std::make_shared<const core::Image>(std::move(exemplar));
    TextonStore* store = &m_store;
    Metrics* metrics = &m_metrics;
    return m_pool.submit(
        id,
        [u, params, store, metrics,
         id](const core::ProgressFn& progress) -> Result<AnalysisOutcome> {
            // An identical upload may have finished while this one queued.
            if (auto meta = store->find(id)) return AnalysisOutcome{meta.value(), false};
            const auto t0 = std::chrono::steady_clock::now();
            auto record = analyse(*u, params, progress);
            const double ms =
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                    .count();
            metrics->analysis(record.ok(), ms);
            if (!record) return record.error();
            auto put = store->put(std::move(record.value()), u.get());
            if (!put) return put.error();
            auto meta = store->find(id);
            if (!meta) return meta.error();
            spdlog::info("analysed {}: {}x{}x{}, r = {}, RME {:.4f}, {:.0f} ms{}", id, u->width,
                         u->height, u->channels, params.size, meta.value().rme, ms,
                         put.value() ? "" : " (another replica stored it first)");
            return AnalysisOutcome{meta.value(), put.value()};
        });
}

} // namespace textond::http
