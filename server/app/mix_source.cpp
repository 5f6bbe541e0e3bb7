#include "server/app/mix_source.h"

namespace textond::app {

Result<int> MixSource::interpolation_order(const std::string& id) const {
    auto found = m_mixes.meta(id);
    if (!found) return found.error();
    return found.value().order;
}

Result<ImageSource::WindowCost> MixSource::cost(const std::string& id,
                                                const api::MapChoice& /*map*/) const {
    auto meta = m_mixes.meta(id);
    if (!meta) return meta.error();
    return WindowCost{1, 0.0, 1, meta.value().size, meta.value().order};
}

std::optional<Error> MixSource::tilejson_refusal(const std::string& id,
                                                 const api::NoiseParams& noise) const {
    if (auto meta = m_mixes.meta(id); !meta) return meta.error();
    if (noise.exemplar_marginals)
        return make_error(ErrorCode::invalid_argument,
                          "marginals=exemplar is for textons of one exemplar: a mix interpolates "
                          "two Gaussian models; use marginals=gaussian");
    return std::nullopt;
}

Result<ImageSource::Evaluate> MixSource::prepare(const std::string& id,
                                                 const render::NoiseRequest& q, Work work,
                                                 const api::MapChoice& map) {
    if (!map.name.empty())
        return make_error(ErrorCode::invalid_argument, "a texture mix has no maps: drop map=");
    auto prepared = m_mixes.prepared(id);
    if (!prepared) return prepared.error();
    if (auto err = prepared.value()->check(q)) return *err;
    return Evaluate([this, mix = std::move(prepared.value()), q, work](std::string* used) {
        return m_renderer.mix(*mix, q, work, used);
    });
}

} // namespace textond::app
