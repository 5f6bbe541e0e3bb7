#include "server/app/image_source.h"

#include <chrono>

namespace textond::app {

render::NoiseRequest to_noise_request(int level, std::int64_t x0, std::int64_t y0, int w, int h,
                                      const api::NoiseParams& noise) {
    render::NoiseRequest q;
    q.level = level;
    q.x0 = x0;
    q.y0 = y0;
    q.width = w;
    q.height = h;
    q.seed = noise.seed;
    q.mni = noise.mni;
    q.marginals =
        noise.exemplar_marginals ? render::Marginals::exemplar : render::Marginals::gaussian;
    return q;
}

Result<core::Image> ImageSource::window(const std::string& id, const render::NoiseRequest& q,
                                        Work work, const char* kind, const api::MapChoice& map) {
    auto evaluate = prepare(id, q, work, map);
    if (!evaluate) return evaluate.error();
    const auto t0 = std::chrono::steady_clock::now();
    std::string used;
    Result<core::Image> image = evaluate.value()(&used);
    if (!used.empty()) // empty: refused before any backend ran
        m_metrics.render(
            used, kind,
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count());
    return image;
}

// The kinds without a report (has_report false) install no route that calls these.
namespace {
Error no_report(const ImageSource& source) {
    return make_error(ErrorCode::not_found,
                      "/v1/" + std::string(source.collection()) + " have no report");
}
} // namespace

Result<std::int64_t> ImageSource::report_work_pixels(const std::string& /*id*/) const {
    return no_report(*this);
}

Result<core::Image> ImageSource::report(const std::string& /*id*/,
                                        const api::NoiseParams& /*noise*/,
                                        const render::Cancel& /*cancel*/) {
    return no_report(*this);
}

} // namespace textond::app
