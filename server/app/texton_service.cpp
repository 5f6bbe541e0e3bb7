#include "server/app/texton_service.h"

#include "server/io/slow_point.h"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <memory>

namespace textond::app {

TextonService::TextonService(store::TextonStore& store, AnalysisPool& pool, Metrics& metrics,
                             WorkSlots& decode_slots, io::DecodeLimits limits,
                             std::chrono::milliseconds decode_wait, double max_work_s)
    : m_store(store), m_pool(pool), m_metrics(metrics), m_decode_slots(decode_slots),
      m_limits(std::move(limits)), m_decode_wait(decode_wait), m_max_work_s(max_work_s) {}

// A shared store that refused its last write (full, read-only) would refuse this texton too:
// answered before the analysis is spent.
std::optional<TextonService::Refused> TextonService::store_refuses_writes() const {
    // So would a data directory that takes no file (read-only, gone): /readyz said 503, and the
    // upload ran its whole analysis before its 500.
    if (!m_store.local().writable())
        return Refused{Refused::Stage::lookup,
                       make_error(ErrorCode::unavailable,
                                  "the data directory takes no new file (read-only or gone); "
                                  "this replica's /readyz says so")};
    const store::RedisStore* shared = m_store.shared();
    if (!shared) return std::nullopt;
    const std::string why = shared->write_refusal();
    if (why.empty()) return std::nullopt;
    return Refused{Refused::Stage::lookup,
                   make_error(ErrorCode::unavailable, "the shared store refuses writes: " + why)};
}

std::optional<TextonService::Refused>
TextonService::over_budget(const core::Image& u, const core::AnalysisParams& p) const {
    const double work = analysis_work_s(u.width, u.height, u.channels, p.iterations, p.size);
    if (m_max_work_s <= 0 || work <= m_max_work_s) return std::nullopt;
    char text[160];
    std::snprintf(text, sizeof text,
                  "the analysis of a %dx%dx%d exemplar at %d iterations would take about %.0f s "
                  "of CPU, over this server's %.0f s: send a smaller exemplar or fewer iterations",
                  u.width, u.height, u.channels, p.iterations, work, m_max_work_s);
    return Refused{Refused::Stage::work, make_error(ErrorCode::too_large, text)};
}

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
    if (admit != WorkSlots::Admit::granted)
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
    if (auto meta = m_store.find(out.id, true)) {
        out.known = std::move(meta.value());
        return out;
    } else if (meta.error().code != ErrorCode::not_found) {
        return Refused{Stage::lookup, meta.error()};
    }
    if (auto refused = store_refuses_writes()) return *refused;
    if (auto refused = over_budget(u, params)) return *refused;
    const double work_s =
        analysis_work_s(u.width, u.height, u.channels, params.iterations, params.size);
    image.value() = core::Image{}; // while queued, the job holds the encoded bytes alone
    auto body = std::make_shared<const std::string>(bytes);
    out.submitted = submit(
        out.id, work_s,
        [body, params, limits = m_limits](const core::ProgressFn& progress) -> Result<Analysed> {
            auto again = io::decode_image_memory(*body, limits);
            if (!again) return again.error();
            auto record = analyse(again.value(), params, progress);
            if (!record) return record.error();
            return Analysed{std::move(record.value()), std::move(again.value())};
        });
    return out;
}

Result<io::TextonRecord> TextonService::analyse_set(const core::Image& stacked,
                                                    const std::vector<api::MapMeta>& maps,
                                                    const core::AnalysisParams& params,
                                                    const core::ProgressFn& progress) {
    std::vector<core::TextonMap> layout;
    layout.reserve(maps.size());
    for (const api::MapMeta& m : maps) layout.push_back({m.name, m.first, m.channels});
    auto result = core::analyze_material_set(stacked, layout, params, progress);
    if (!result) return result.error();
    return io::make_set_record(stacked, maps, params, result.value());
}

std::optional<TextonService::Refused>
TextonService::decode_maps(const std::vector<MapUpload>& maps, core::Image& stacked,
                           std::vector<api::MapMeta>& meta, const std::function<bool()>& gone) {
    using Stage = Refused::Stage;
    const auto admit = m_decode_slots.acquire(m_decode_wait, gone);
    if (admit != WorkSlots::Admit::granted)
        return Refused{Stage::busy, make_error(ErrorCode::unavailable, "no decoder"), admit};
    SlotGuard slot(&m_decode_slots);
    return stack_maps(maps, m_limits, stacked, meta);
}

std::optional<TextonService::Refused> TextonService::stack_maps(const std::vector<MapUpload>& maps,
                                                                const io::DecodeLimits& limits,
                                                                core::Image& stacked,
                                                                std::vector<api::MapMeta>& meta) {
    using Stage = Refused::Stage;
    std::vector<core::Image> images;
    int channels = 0;
    // A set's pixels in all: at most an RGB exemplar's worth (--max-pixels times 3 channels), so
    // eight maps cannot hold eight times an upload's memory (with the stacked copy, twice that).
    const std::uint64_t budget = 3 * limits.max_pixels;
    std::uint64_t held = 0;
    for (const MapUpload& m : maps) {
        int bits = 8;
        auto image = io::decode_image_memory(m.bytes, limits, &bits);
        if (!image)
            return Refused{Stage::decode, Error{image.error().code,
                                                "map '" + m.name + "': " + image.error().message}};
        core::Image u = std::move(image.value());
        if (m.name != "albedo" && u.channels == 3) { // a grey map saved as RGB: its mean
            core::Image g(u.width, u.height, 1);
            for (std::size_t k = 0; k < g.plane_size(); ++k)
                g.data[k] = (u.plane(0)[k] + u.plane(1)[k] + u.plane(2)[k]) / 3.0f;
            u = std::move(g);
        }
        if (!images.empty() && (u.width != images[0].width || u.height != images[0].height))
            return Refused{Stage::size,
                           make_error(ErrorCode::invalid_argument,
                                      "map '" + m.name + "' is " + std::to_string(u.width) + "x" +
                                          std::to_string(u.height) + ", map '" + maps[0].name +
                                          "' " + std::to_string(images[0].width) + "x" +
                                          std::to_string(images[0].height) +
                                          ": every map of a set must have one size")};
        held += static_cast<std::uint64_t>(u.plane_size()) * static_cast<std::uint64_t>(u.channels);
        if (held > budget)
            return Refused{Stage::decode,
                           make_error(ErrorCode::too_large,
                                      "the set's maps hold " + std::to_string(held) +
                                          " channel-pixels by map '" + m.name + "', over " +
                                          std::to_string(budget) +
                                          " (an RGB exemplar of --max-pixels): use smaller maps")};
        meta.push_back({m.name, channels, u.channels, bits, {}, 0.0});
        channels += u.channels;
        images.push_back(std::move(u));
    }
    if (channels > core::kMaxChannels)
        return Refused{Stage::size,
                       make_error(ErrorCode::invalid_argument,
                                  "a set has at most " + std::to_string(core::kMaxChannels) +
                                      " channels, these maps have " + std::to_string(channels))};
    stacked = core::Image(images[0].width, images[0].height, channels);
    for (std::size_t i = 0; i < images.size(); ++i)
        std::copy(images[i].data.begin(), images[i].data.end(), stacked.plane(meta[i].first));
    return std::nullopt;
}

std::variant<TextonService::Ingested, TextonService::Refused>
TextonService::ingest_set(const std::vector<MapUpload>& maps, const core::AnalysisParams& params,
                          const std::function<bool()>& gone) {
    using Stage = Refused::Stage;
    // Channel order is the canonical map order, whatever the form's order.
    std::vector<MapUpload> ordered;
    for (const char* name : core::kMapNames)
        for (const MapUpload& m : maps)
            if (m.name == name) ordered.push_back(m);
    core::Image stacked;
    std::vector<api::MapMeta> meta;
    if (auto refused = decode_maps(ordered, stacked, meta, gone)) return *refused;
    if (auto err = core::validate_analysis(params, stacked.width, stacked.height, 1))
        return Refused{Stage::check, *err};
    Ingested out;
    out.id = io::texton_id(stacked, params, meta);
    if (auto known = m_store.find(out.id, true)) {
        out.known = std::move(known.value());
        return out;
    } else if (known.error().code != ErrorCode::not_found) {
        return Refused{Stage::lookup, known.error()};
    }
    if (auto refused = store_refuses_writes()) return *refused;
    if (auto refused = over_budget(stacked, params)) return *refused;
    const double work_s = analysis_work_s(stacked.width, stacked.height, stacked.channels,
                                          params.iterations, params.size);
    stacked = core::Image{}; // while queued, the job holds the encoded maps alone
    // The maps' bytes outlive the request (a client that polls has left it).
    auto kept = std::make_shared<std::vector<std::pair<std::string, std::string>>>();
    for (const MapUpload& m : ordered) kept->emplace_back(m.name, std::string(m.bytes));
    out.submitted = submit(
        out.id, work_s,
        [kept, params, limits = m_limits](const core::ProgressFn& progress) -> Result<Analysed> {
            std::vector<MapUpload> again;
            for (const auto& [name, bytes] : *kept) again.push_back({name, bytes});
            core::Image u;
            std::vector<api::MapMeta> layout;
            if (auto refused = stack_maps(again, limits, u, layout)) return refused->error;
            auto record = analyse_set(u, layout, params, progress);
            if (!record) return record.error();
            return Analysed{std::move(record.value()),
                            core::channel_planes(u, layout[0].first, layout[0].channels)};
        });
    return out;
}

AnalysisPool::Submitted TextonService::submit(const std::string& id, double work_s,
                                              const Analyse& analyse) {
    store::TextonStore* store = &m_store;
    Metrics* metrics = &m_metrics;
    return m_pool.submit(
        id,
        [analyse, store, metrics, id,
         work_s](const core::ProgressFn& progress) -> Result<AnalysisOutcome> {
            // An identical upload may have finished while this one queued.
            if (auto meta = store->find(id)) return AnalysisOutcome{meta.value(), false};
            io::slow_point("analysis", work_s);
            const auto t0 = std::chrono::steady_clock::now();
            auto made = analyse(progress);
            const double ms =
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                    .count();
            metrics->analysis(made.ok(), ms);
            if (!made) return made.error();
            const core::Image& u = made.value().shown;
            auto put = store->put(std::move(made.value().record), &u);
            if (!put) return put.error();
            auto meta = store->find(id);
            if (!meta) return meta.error();
            spdlog::info("analysed {}: {}x{}x{}, r = {}, RME {:.4f}, {:.0f} ms{}", id, u.width,
                         u.height, meta.value().channels, meta.value().size, meta.value().rme, ms,
                         put.value() ? "" : " (another replica stored it first)");
            return AnalysisOutcome{meta.value(), put.value()};
        });
}

} // namespace textond::app
