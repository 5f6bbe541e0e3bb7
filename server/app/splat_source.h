#pragma once
// A splat map's images: up to eight textons' noise blended by its weights, and its report.
#include "server/app/image_source.h"
#include "server/store/splat_store.h"

namespace textond::app {

// The colour (RGB in [0, 1]) of splat layer `layer` (0..7) in a splat's report.
const float* splat_palette(int layer);

class SplatSource final : public ImageSource {
public:
    SplatSource(store::SplatStore& splats, render::Renderer& renderer, Metrics& metrics)
        : ImageSource(renderer, metrics), m_splats(splats) {}

    const char* collection() const override { return "splats"; }
    const char* described_as() const override { return "Splat map "; }
    bool has_maps() const override { return false; }
    bool has_report() const override { return true; }
    Result<int> interpolation_order(const std::string& id) const override;
    // At most a render a layer, and its rules' height and normals.
    Result<WindowCost> cost(const std::string& id, const api::MapChoice& map) const override;
    std::optional<Error> tilejson_refusal(const std::string& id,
                                          const api::NoiseParams& noise) const override;
    // Its weights (each layer a colour of splat_palette) beside its render, one 256 x 256 window
    // at the level that shows the whole weight image (level 2 for rules).
    Result<std::int64_t> report_work_pixels(const std::string& id) const override;
    Result<core::Image> report(const std::string& id, const api::NoiseParams& noise,
                               const render::Cancel& cancel) override;

protected:
    Result<Evaluate> prepare(const std::string& id, const render::NoiseRequest& q, Work work,
                             const api::MapChoice& map) override;

private:
    store::SplatStore& m_splats;
};

} // namespace textond::app
