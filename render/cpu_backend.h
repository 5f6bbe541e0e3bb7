#pragma once
// The reference evaluator and the fast path without a GPU: direct summation (SOT paper,
// Algorithm 1) of every point's texton into cache-sized blocks of the window, in the global point
// order of NOISE_SPEC.md section 7, so any tiling and any thread count give the same bits.
#include "render/backend.h"
#include "render/prepared_mix.h"

#include <vector>

namespace textond::render {

class CpuBackend final : public Backend {
public:
    // threads 0 = all hardware threads; block = side of the accumulator blocks in pixels.
    explicit CpuBackend(int threads = 0, int block = 128);
    std::string name() const override { return "cpu"; }
    std::string renderer() const override;
    Result<core::Image> render(const PreparedTexton& texton, const NoiseRequest& request,
                               RenderStats* stats = nullptr) override;
    // A texture mix (texton-noise section 7): every Poisson point takes the level texton of the
    // field at its position, the mean follows the field (GlBackend::render_mix on GL).
    Result<core::Image> render_mix(const PreparedMix& mix, const NoiseRequest& request,
                                   RenderStats* stats = nullptr) override;

    // d/dx (axis 0) or d/dy (axis 1) of the noise, per texel, with the value's sampling and box
    // filtering: the kernel's derivative applied to the level's table (at level k > 0 the box
    // average of level 0's derivative). Exact levels and orders 1 and 3 only; no marginals.
    Result<core::Image> render_gradient(const PreparedTexton& texton, const NoiseRequest& request,
                                        int axis);

private:
    // The noise before any marginal restoration.
    Result<core::Image> render_gaussian(const PreparedTexton& tex, const NoiseRequest& q,
                                        RenderStats* stats);
    Result<core::Image> render_exact(const PreparedTexton& tex,
                                     const std::vector<const LevelTable*>& tables,
                                     const PreparedMix* mix, const NoiseRequest& q,
                                     RenderStats* stats, int deriv = -1);
    int m_threads;
    int m_block;
};

} // namespace textond::render
