#include "core/material_set.h"

#include "core/periodic_component.h"
#include "core/rme.h"

#include <chrono>
#include <cstring>

namespace textond::core {

std::optional<Error> validate_maps(const std::vector<TextonMap>& maps, int channels) {
    auto bad = [](const std::string& m) { return make_error(ErrorCode::invalid_argument, m); };
    if (maps.empty()) return bad("a material set needs at least one map");
    int next = 0;
    for (std::size_t i = 0; i < maps.size(); ++i) {
        const TextonMap& m = maps[i];
        bool known = false;
        for (const char* n : kMapNames) known = known || m.name == n;
        if (!known) return bad("unknown map '" + m.name + "'");
        for (std::size_t j = 0; j < i; ++j)
            if (maps[j].name == m.name) return bad("map '" + m.name + "' given twice");
        const bool colour = m.name == "albedo";
        if (!(m.channels == 1 || (colour && m.channels == 3)))
            return bad("map '" + m.name + "' must have " +
                       (colour ? "1 or 3 channels" : "1 channel"));
        if (m.first != next) return bad("maps must be laid out side by side from channel 0");
        next += m.channels;
    }
    if (next != channels || channels > kMaxChannels)
        return bad("the maps have " + std::to_string(next) + " channels, the set " +
                   std::to_string(channels) + " (at most " + std::to_string(kMaxChannels) + ")");
    return std::nullopt;
}

const TextonMap* find_map(const std::vector<TextonMap>& maps, const std::string& name) {
    for (const TextonMap& m : maps)
        if (m.name == name) return &m;
    return nullptr;
}

Image channel_planes(const Image& u, int first, int count) {
    Image out(u.width, u.height, count);
    std::memcpy(out.data.data(), u.plane(first), out.data.size() * sizeof(float));
    return out;
}

GaussianModel channel_subset(const GaussianModel& m, int first, int count) {
    GaussianModel s;
    s.width = m.width;
    s.height = m.height;
    s.channels = count;
    s.t_u = channel_planes(m.t_u, first, count);
    s.covariance.n = count;
    for (int c = 0; c < count; ++c) {
        s.mean[static_cast<std::size_t>(c)] = m.mean[static_cast<std::size_t>(first + c)];
        s.t_hat.push_back(m.t_hat[static_cast<std::size_t>(first + c)]);
        for (int d = 0; d < count; ++d) s.covariance(c, d) = m.covariance(first + c, first + d);
    }
    return s;
}

Result<SetAnalysis> analyze_material_set(const Image& stacked, const std::vector<TextonMap>& maps,
                                         const AnalysisParams& params, const ProgressFn& progress) {
    if (auto err = validate_maps(maps, stacked.channels)) return *err;
    // The size and parameter rules of a single exemplar, checked on its first map's shape.
    if (auto err = validate_analysis(params, stacked.width, stacked.height, 1)) return *err;
    const auto t_start = std::chrono::steady_clock::now();
    const int threads = resolve_threads(params.threads);
    // SOT paper section 3.1, on the working window of large maps.
    const Image crop = working_window(stacked, params.working_side, 2 * params.size);
    const Image& window = crop.empty() ? stacked : crop;
    const Image p = params.periodic ? periodic_component(window, threads) : window;
    const GaussianModel model = estimate_gaussian_model(p, threads);
    SetAnalysis out;
    out.result = texton_from_model(model, params, progress);
    const Image& alpha = out.result.texton.alpha;
    for (const TextonMap& m : maps)
        out.map_rme.push_back(relative_model_error(channel_subset(model, m.first, m.channels),
                                                   channel_planes(alpha, m.first, m.channels),
                                                   params.order, 0, 0, threads));
    const TextonMap& first = maps.front();
    const Image first_map = channel_planes(window, first.first, first.channels);
    out.result.coherence = phase_coherence(first_map, threads);
    out.result.shape = shape_verdict(first_map, threads);
    out.result.texton.maps = maps;
    out.result.timings.total_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_start)
            .count();
    return out;
}

} // namespace textond::core
