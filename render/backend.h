#pragma once
// One interface for every way of evaluating texton noise (style.md: Filament's OpenGLPlatform).
// A backend evaluates a window of NOISE_SPEC.md into a planar float image with the texton's
// channels; it is deterministic (same request, same bytes) and safe to call from many threads.
#include "core/image.h"
#include "core/result.h"
#include "render/noise_request.h"
#include "render/prepared_mix.h"
#include "render/prepared_texton.h"

#include <string>

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
