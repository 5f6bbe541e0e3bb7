#include "core/noise_levels.h"

#include "core/noise_hash.h"

#include <cmath>
#include <stdexcept>
#include <vector>

namespace textond::core::noise {

int limit_level(int r) {
    int k = 1;
    while ((std::int64_t{1} << (k + 1)) <= r) ++k;
    return k;
}

Image box_filtered_coefficients(const Image& alpha, int st) {
    if (st < 1) throw std::invalid_argument("box_filtered_coefficients: st < 1");
    const int r = alpha.width, n = r + st - 1;
    Image g(n, n, alpha.channels);
    // Summed-area table of alpha with a zero first row and column.
    std::vector<double> sat(static_cast<std::size_t>(r + 1) * (r + 1));
    auto s = [&](int x, int y) -> double& {
        return sat[static_cast<std::size_t>(y) * (r + 1) + static_cast<std::size_t>(x)];
    };
    auto box = [&](int x0, int y0) { // sum over [x0, x0+st) x [y0, y0+st), clipped to [0, r)^2
        const int xa = std::max(0, x0), ya = std::max(0, y0);
        const int xb = std::min(r, x0 + st), yb = std::min(r, y0 + st);
        if (xa >= xb || ya >= yb) return 0.0;
        return s(xb, yb) - s(xa, yb) - s(xb, ya) + s(xa, ya);
    };
    const double inv = 1.0 / (static_cast<double>(st) * st);
    for (int c = 0; c < alpha.channels; ++c) {
        for (int y = 0; y < r; ++y)
            for (int x = 0; x < r; ++x)
                s(x + 1, y + 1) = alpha.at(c, x, y) + s(x, y + 1) + s(x + 1, y) - s(x, y);
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x)
                g.at(c, x, y) = static_cast<float>(box(x - (st - 1), y - (st - 1)) * inv);
    }
    return g;
}

LimitModel limit_model(const LagCovariance& cov, std::int64_t st) {
    LimitModel m;
    const ColourMatrix c0 = box_average_covariance(cov, st, 0, 0);
    m.a = sqrt_psd(c0);
    double trace0 = 0.0;
    for (int c = 0; c < c0.n; ++c) trace0 += c0(c, c);
    m.kappa.fill(0.0);
    if (!(trace0 > 0.0)) {
        m.kappa[12] = 1.0;
        return m;
    }
    double rho[5][5];
    for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) {
            const ColourMatrix cd = box_average_covariance(cov, st, dx, dy);
            double tr = 0.0;
            for (int c = 0; c < cd.n; ++c) tr += cd(c, c);
            rho[dy + 2][dx + 2] = tr / trace0;
        }
    // Spectral square root on a 16 x 16 torus; rho is even, so its DFT is real.
    constexpr int N = 16;
    const double w = 2.0 * M_PI / N;
    double root[N][N];
    for (int v = 0; v < N; ++v)
        for (int u = 0; u < N; ++u) {
            double s = 0.0;
            for (int dy = -2; dy <= 2; ++dy)
                for (int dx = -2; dx <= 2; ++dx)
                    s += rho[dy + 2][dx + 2] * std::cos(w * (u * dx + v * dy));
            root[v][u] = std::sqrt(std::max(0.0, s));
        }
    double norm = 0.0;
    for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) {
            double s = 0.0;
            for (int v = 0; v < N; ++v)
                for (int u = 0; u < N; ++u) s += root[v][u] * std::cos(w * (u * dx + v * dy));
            s /= N * N;
            m.kappa[static_cast<std::size_t>((dy + 2) * 5 + dx + 2)] = s;
            norm += s * s;
        }
    for (double& k : m.kappa) k /= std::sqrt(norm);
    return m;
}

void pixel_normals(std::uint64_t seed, int level, std::int64_t px, std::int64_t py, int channels,
                   float* out) {
    Stream32 s(pixel_key(seed, level, px, py));
    for (int c = 0; c < channels; c += 2) {
        // Float, as in the GLSL: the u are exact 24-bit values, the functions within a few ulp.
        const float u1 = static_cast<float>((s.next() >> 8) + 1) * (1.0f / 16777216.0f);
        const float u2 = static_cast<float>(s.next() >> 8) * (1.0f / 16777216.0f);
        const float rr = std::sqrt(-2.0f * std::log(u1));
        const float angle = 6.28318530717958647f * u2;
        out[c] = rr * std::cos(angle);
        if (c + 1 < channels) out[c + 1] = rr * std::sin(angle);
    }
}

} // namespace textond::core::noise
