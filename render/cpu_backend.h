#pragma once
// The reference evaluator and the fast path without a GPU: direct summation (SOT paper,
// Algorithm 1) of every point's texton into cache-sized blocks of the window, in the global point
// order of NOISE_SPEC.md section 7, so any tiling and any thread count give the same bits.
#include "render/backend.h"

namespace textond::render {

class CpuBackend final : public Backend {
public:
    // threads 0 = all hardware threads; block = side of the accumulator blocks in pixels.
    explicit CpuBackend(int threads = 0, int block = 128);
    std::string name() const override { return "cpu"; }
    std::string renderer() const override;
    Result<core::Image> render(const PreparedTexton& texton, const NoiseRequest& request,
                               RenderStats* stats = nullptr) override;

private:
    int m_threads;
    int m_block;
};

} // namespace textond::render
