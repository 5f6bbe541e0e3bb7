#include "server/cli/window_options.h"

#include <cstdint>

namespace textond::cli {

Result<render::NoiseRequest> window_from(const Args& a, int width, int height) {
    auto x = a.get_int("--x", 0, INT64_MIN, INT64_MAX);
    auto y = a.get_int("--y", 0, INT64_MIN, INT64_MAX);
    auto w = a.get_int("--w", width, 1, render::kMaxWindowSide);
    auto h = a.get_int("--h", height, 1, render::kMaxWindowSide);
    auto lod = a.get_int("--lod", 0, -4, 24);
    auto mni = a.get_double("--mni", render::kDefaultMni, 1.0, 200.0);
    for (const Error* e :
         {x ? nullptr : &x.error(), y ? nullptr : &y.error(), w ? nullptr : &w.error(),
          h ? nullptr : &h.error(), lod ? nullptr : &lod.error(), mni ? nullptr : &mni.error()})
        if (e) return *e;
    render::NoiseRequest q;
    q.x0 = x.value();
    q.y0 = y.value();
    q.width = static_cast<int>(w.value());
    q.height = static_cast<int>(h.value());
    q.level = static_cast<int>(lod.value());
    q.mni = mni.value();
    // Only commands that list --marginals accept it (render); the others keep the default.
    const std::string marginals = a.get("--marginals", "gaussian");
    if (marginals != "gaussian" && marginals != "exemplar")
        return make_error(ErrorCode::invalid_argument,
                          "--marginals must be gaussian or exemplar, not '" + marginals + "'");
    q.marginals =
        marginals == "exemplar" ? render::Marginals::exemplar : render::Marginals::gaussian;
    return q;
}

} // namespace textond::cli
