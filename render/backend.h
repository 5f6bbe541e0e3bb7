#pragma once
// One interface for every way of evaluating texton noise (style.md: Filament's OpenGLPlatform).
// A backend evaluates a window of NOISE_SPEC.md into a planar float image with the texton's
// channels; it is deterministic (same request, same bytes) and safe to call from many threads.
// Requests arrive checked (PreparedTexton::check, PreparedMix::check: the one place their rules
// live, called by whoever builds the request); a backend asserts it in debug builds.
#include "core/image.h"
#include "core/result.h"
#include "render/noise_request.h"
#include "render/prepared_mix.h"
#include "render/prepared_texton.h"

#include <string>
#include <vector>

namespace textond::render {

class Backend {
public:
    virtual ~Backend() = default;
    // "cpu", "osmesa" or "egl".
    virtual std::string name() const = 0;
    // What actually runs: thread count and instruction set, or GL_RENDERER.
    virtual std::string renderer() const = 0;
    virtual Result<core::Image> render(const PreparedTexton& texton, const NoiseRequest& request,
                                       RenderStats* stats = nullptr) = 0;
    // Many windows of one texton at once (the calibration's tiles, bench's batch): a GL backend
    // renders them as one batch; the default renders them one after another.
    // `stats`, when given, receives the GPU time of all of them (-1 on the CPU).
    virtual std::vector<Result<core::Image>> render_many(const PreparedTexton& texton,
                                                         const std::vector<NoiseRequest>& requests,
                                                         RenderStats* stats = nullptr) {
        std::vector<Result<core::Image>> out;
        out.reserve(requests.size());
        for (const auto& q : requests) out.push_back(render(texton, q));
        if (stats) stats->gpu_ms = -1;
        return out;
    }
    // A texture mix (NOISE_SPEC.md section 9). ErrorCode::unsupported where this backend has no
    // path for the request (the caller then uses the CPU backend, which has them all).
    virtual Result<core::Image> render_mix(const PreparedMix& mix, const NoiseRequest& request,
                                           RenderStats* stats = nullptr) {
        (void)mix;
        (void)request;
        (void)stats;
        return make_error(ErrorCode::unsupported, name() + " does not render texture mixes");
    }
};

} // namespace textond::render
