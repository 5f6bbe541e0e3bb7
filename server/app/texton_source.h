#pragma once
// A texton's (or material set's) images: its noise and its maps' views (map=), its quality
// report, and what only a texton has: the spectrum beside its exemplar's.
#include "server/app/image_source.h"
#include "server/app/quality_report.h"
#include "server/store/texton_store.h"

#include <memory>

namespace textond::app {

using PreparedTextonResult = Result<std::shared_ptr<const render::PreparedTexton>>;

// The pixels of a view (api::MapChoice) of a texton or material set: the texton's noise, a set's
// map, its normals or its lit albedo. `used` names the backend that ran; it stays empty when
// the request was refused before any did. `textond export` calls it too.
Result<core::Image> render_view(render::Renderer& renderer, const PreparedTextonResult& set,
                                const api::MapChoice& map, const render::NoiseRequest& q,
                                render::Renderer::Work work, std::string* used);

class TextonSource final : public ImageSource {
public:
    TextonSource(store::TextonStore& textons, render::Renderer& renderer, Metrics& metrics)
        : ImageSource(renderer, metrics), m_textons(textons) {}

    const char* collection() const override { return "textons"; }
    const char* described_as() const override { return "Texton noise of texton "; }
    bool has_maps() const override { return true; }
    bool has_report() const override { return true; }
    Result<int> interpolation_order(const std::string& id) const override;
    Result<WindowCost> cost(const std::string& id, const api::MapChoice& map) const override;
    std::optional<Error> tilejson_refusal(const std::string& id,
                                          const api::NoiseParams& noise) const override;
    // The quality report's PNG (two windows of at most 256 x 256).
    Result<std::int64_t> report_work_pixels(const std::string& id) const override;
    Result<core::Image> report(const std::string& id, const api::NoiseParams& noise,
                               const render::Cancel& cancel) override;

    // The quality report (quality_report.h): its exemplar's centre crop (at most 256 x 256)
    // beside level-0 windows of its noise, Gaussian and restored.
    Result<QualityReport> quality(const std::string& id, const api::NoiseParams& noise,
                                  const render::Cancel& cancel);
    // The exemplar's power spectrum beside that of a window of its noise, on one log scale, and
    // its image cache key.
    Result<core::Image> spectrum(const std::string& id, const api::NoiseParams& noise,
                                 const render::Cancel& cancel);
    std::string spectrum_key(const std::string& id, const api::NoiseParams& noise) const;
    store::TextonStore& store() const { return m_textons; }

protected:
    Result<Evaluate> prepare(const std::string& id, const render::NoiseRequest& q, Work work,
                             const api::MapChoice& map) override;

private:
    store::TextonStore& m_textons;
};

} // namespace textond::app
