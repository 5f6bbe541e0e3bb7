#include "render/prepared_splat.h"

#include <algorithm>

namespace textond::render {

Result<std::shared_ptr<const PreparedSplat>>
PreparedSplat::make(std::vector<std::shared_ptr<const PreparedTexton>> layers,
                    core::SplatWeights weights, std::shared_ptr<const PreparedTexton> height) {
    const int k = static_cast<int>(layers.size());
    if (auto err = weights.validate(k)) return *err;
    const bool rules = weights.kind == core::SplatWeights::Kind::rules;
    if (rules != (height != nullptr))
        return make_error(ErrorCode::invalid_argument,
                          rules ? "rules weights need a height field" : "image weights take none");
    std::shared_ptr<PreparedSplat> s(new PreparedSplat());
    for (const auto& l : layers) {
        if (!l) return make_error(ErrorCode::invalid_argument, "a splat layer is missing");
        if (l->channels() != 1 && l->channels() != 3)
            return make_error(ErrorCode::invalid_argument,
                              "splat layers are grey or RGB textons, not material sets");
        s->m_channels = std::max(s->m_channels, l->channels());
    }
    s->m_layers = std::move(layers);
    s->m_weights = std::move(weights);
    s->m_height = std::move(height);
    return std::shared_ptr<const PreparedSplat>(std::move(s));
}

int PreparedSplat::order() const {
    int o = 0;
    for (const auto& l : m_layers) o = std::max(o, l->order());
    return m_height ? std::max(o, m_height->order()) : o;
}

std::optional<Error> PreparedSplat::check(const NoiseRequest& q) const {
    if (q.period[0] != 0 || q.period[1] != 0)
        return make_error(ErrorCode::invalid_argument,
                          "splats have no tileable mode: their weights are not periodic");
    if (q.marginals == Marginals::exemplar)
        return make_error(ErrorCode::invalid_argument,
                          "splats blend Gaussian layers, whose exemplar marginals the blend does "
                          "not keep; use marginals=gaussian");
    for (const auto& l : m_layers)
        if (auto err = l->check(q)) return err;
    if (m_height)
        if (auto err = m_height->check(q)) return err;
    return std::nullopt;
}

} // namespace textond::render
