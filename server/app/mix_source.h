#pragma once
// A texture mix's images: its noise, two textons' Gaussian models interpolated over its field.
#include "server/app/image_source.h"
#include "server/store/mix_store.h"

namespace textond::app {

class MixSource final : public ImageSource {
public:
    MixSource(store::MixStore& mixes, render::Renderer& renderer, Metrics& metrics)
        : ImageSource(renderer, metrics), m_mixes(mixes) {}

    const char* collection() const override { return "mixes"; }
    const char* described_as() const override { return "Texture mix "; }
    bool has_maps() const override { return false; }
    bool has_report() const override { return false; }
    Result<int> interpolation_order(const std::string& id) const override;
    Result<WindowCost> cost(const std::string& id, const api::MapChoice& map) const override;
    std::optional<Error> tilejson_refusal(const std::string& id,
                                          const api::NoiseParams& noise) const override;

protected:
    Result<Evaluate> prepare(const std::string& id, const render::NoiseRequest& q, Work work,
                             const api::MapChoice& map) override;

private:
    store::MixStore& m_mixes;
};

} // namespace textond::app
