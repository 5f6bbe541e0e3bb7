#include "server/app/splat_source.h"

#include "core/noise_levels.h"

#include <algorithm>
#include <cmath>

namespace textond::app {

namespace {
constexpr int kReportSide = 256, kReportGap = 4;
} // namespace

const float* splat_palette(int layer) {
    // Distinct under the common colour-vision deficiencies (Okabe and Ito), layer 1 first.
    static const float kPalette[core::kMaxSplatLayers][3] = {
        {0.90f, 0.62f, 0.00f}, {0.34f, 0.71f, 0.91f}, {0.00f, 0.62f, 0.45f}, {0.94f, 0.89f, 0.26f},
        {0.00f, 0.45f, 0.70f}, {0.84f, 0.37f, 0.00f}, {0.80f, 0.47f, 0.65f}, {0.60f, 0.60f, 0.60f}};
    return kPalette[layer];
}

Result<int> SplatSource::interpolation_order(const std::string& id) const {
    auto found = m_splats.prepared(id);
    if (!found) return found.error();
    return found.value()->order();
}

Result<ImageSource::WindowCost> SplatSource::cost(const std::string& id,
                                                  const api::MapChoice& /*map*/) const {
    auto found = m_splats.prepared(id);
    if (!found) return found.error();
    const render::PreparedSplat& splat = *found.value();
    int size = splat.layer(0).size();
    for (int k = 1; k < splat.layers(); ++k) size = std::min(size, splat.layer(k).size());
    return WindowCost{splat.layers() + 3, 0.0, splat.layers(), size, splat.order()};
}

std::optional<Error> SplatSource::tilejson_refusal(const std::string& id,
                                                   const api::NoiseParams& noise) const {
    if (auto found = m_splats.prepared(id); !found) return found.error();
    if (noise.exemplar_marginals)
        return make_error(ErrorCode::invalid_argument,
                          "splats blend Gaussian layers, whose exemplar marginals the blend does "
                          "not keep; use marginals=gaussian");
    return std::nullopt;
}

Result<ImageSource::Evaluate> SplatSource::prepare(const std::string& id,
                                                   const render::NoiseRequest& q, Work work,
                                                   const api::MapChoice& map) {
    if (!map.name.empty())
        return make_error(ErrorCode::invalid_argument, "a splat map has no maps: drop map=");
    auto prepared = m_splats.prepared(id);
    if (!prepared) return prepared.error();
    if (auto err = prepared.value()->check(q)) return *err;
    return Evaluate([this, splat = std::move(prepared.value()), q, work](std::string* used) {
        return m_renderer.splat(*splat, q, work, used);
    });
}

Result<std::int64_t> SplatSource::report_work_pixels(const std::string& id) const {
    auto found = m_splats.prepared(id);
    if (!found) return found.error();
    return std::int64_t{found.value()->layers() + 4} * kReportSide * kReportSide;
}

Result<core::Image> SplatSource::report(const std::string& id, const api::NoiseParams& noise,
                                        const render::Cancel& cancel) {
    auto prepared = m_splats.prepared(id);
    if (!prepared) return prepared.error();
    const render::PreparedSplat& s = *prepared.value();
    int level = 2;
    std::int64_t x0 = 0, y0 = 0;
    if (s.weights().kind == core::SplatWeights::Kind::image) {
        // The coarsest level whose 256 pixels span the weight image, from its corner.
        const core::SplatImage& im = s.weights().image;
        const double extent = im.scale * std::max(im.weights.width, im.weights.height);
        level = 0;
        while (level < core::noise::kMaxLevel && std::ldexp(kReportSide, level) < extent) ++level;
        x0 = static_cast<std::int64_t>(std::floor(std::ldexp(im.x0, -level)));
        y0 = static_cast<std::int64_t>(std::floor(std::ldexp(im.y0, -level)));
    }
    render::NoiseRequest q = to_noise_request(level, x0, y0, kReportSide, kReportSide, noise);
    q.cancel = &cancel;
    auto weights = m_renderer.splat_weights(s, q, Work::frame);
    if (!weights) return weights.error();
    auto result = window(id, q, Work::frame, "quality");
    if (!result) return result.error();
    core::Image out(2 * kReportSide + kReportGap, kReportSide, 3, 1.0f);
    for (int y = 0; y < kReportSide; ++y)
        for (int x = 0; x < kReportSide; ++x)
            for (int c = 0; c < 3; ++c) {
                double v = 0;
                for (int k = 0; k < s.layers(); ++k)
                    v += weights.value().at(k, x, y) * splat_palette(k)[c];
                out.at(c, x, y) = static_cast<float>(v);
                out.at(c, kReportSide + kReportGap + x, y) =
                    result.value().at(std::min(c, result.value().channels - 1), x, y);
            }
    return out;
}

} // namespace textond::app
