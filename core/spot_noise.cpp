#include "core/spot_noise.h"

#include "core/random.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace textond::core {

Image discrete_spot_noise(const Texton& texton, double mni, std::uint64_t seed, const Window& w) {
    if (!(mni > 0.0) || w.width <= 0 || w.height <= 0 || texton.size <= 0)
        throw std::invalid_argument("discrete_spot_noise: empty window, texton or mni <= 0");
    const int r = texton.size, nc = texton.channels;
    const double lambda = mni / (static_cast<double>(r) * r);
    const int ew = w.width + r - 1, eh = w.height + r - 1; // Omega - S
    Rng rng(seed, 0xd5);
    const std::uint64_t n = rng.poisson(lambda * ew * eh);

    Image out(w.width, w.height, nc);
    for (std::uint64_t i = 0; i < n; ++i) {
        // Point in window coordinates: x_i in [-(r-1), width).
        const int px = static_cast<int>(rng.below(static_cast<std::uint64_t>(ew))) - (r - 1);
        const int py = static_cast<int>(rng.below(static_cast<std::uint64_t>(eh))) - (r - 1);
        const int x_lo = std::max(0, px), x_hi = std::min(w.width, px + r);
        const int y_lo = std::max(0, py), y_hi = std::min(w.height, py + r);
        for (int c = 0; c < nc; ++c)
            for (int y = y_lo; y < y_hi; ++y) {
                const float* src = texton.alpha.plane(c) + static_cast<std::size_t>(y - py) * r;
                float* dst = &out.at(c, 0, y);
                for (int x = x_lo; x < x_hi; ++x) dst[x] += src[x - px];
            }
    }
    const double inv_sqrt_lambda = 1.0 / std::sqrt(lambda);
    for (int c = 0; c < nc; ++c) {
        double sum = 0.0;
        const float* a = texton.alpha.plane(c);
        for (std::size_t k = 0; k < texton.alpha.plane_size(); ++k) sum += a[k];
        const double offset =
            texton.mean[static_cast<std::size_t>(c)] - lambda * sum * inv_sqrt_lambda;
        float* p = out.plane(c);
        for (std::size_t k = 0; k < out.plane_size(); ++k)
            p[k] = static_cast<float>(p[k] * inv_sqrt_lambda + offset);
    }
    return out;
}

} // namespace textond::core
