#pragma once
// A splat map made ready for evaluation: 2 to 8 prepared layer textons, their weights (an image
// on the plane, or rules on a height field whose prepared texton it keeps) and the blend of
// core/splat_blend.h. Evaluated by Renderer::splat on whatever backend renders the layers.
#include "core/splat_blend.h"
#include "render/prepared_texton.h"

#include <memory>
#include <vector>

namespace textond::render {

class PreparedSplat {
public:
    // `height`: the height field of rules weights (its channel 0), null for image weights.
    static Result<std::shared_ptr<const PreparedSplat>>
    make(std::vector<std::shared_ptr<const PreparedTexton>> layers, core::SplatWeights weights,
         std::shared_ptr<const PreparedTexton> height = nullptr);

    int layers() const { return static_cast<int>(m_layers.size()); }
    const PreparedTexton& layer(int k) const { return *m_layers[static_cast<std::size_t>(k)]; }
    const core::SplatWeights& weights() const { return m_weights; }
    const PreparedTexton* height() const { return m_height.get(); }
    // 3 when any layer has colour (a grey layer shows as grey), else 1.
    int channels() const { return m_channels; }
    // The largest interpolation order of its layers and height: what admission costs a window at.
    int order() const;

    std::optional<Error> check(const NoiseRequest& req) const;

private:
    PreparedSplat() = default;
    std::vector<std::shared_ptr<const PreparedTexton>> m_layers;
    core::SplatWeights m_weights;
    std::shared_ptr<const PreparedTexton> m_height;
    int m_channels = 1;
};

} // namespace textond::render
