#include "core/texton_covariance.h"

#include "core/bspline.h"
#include "core/fft2d.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace textond::core {

LagCovariance::LagCovariance(int radius, int channels)
    : m_radius(radius), m_channels(channels),
      m_data(static_cast<std::size_t>(channels) * channels * (2 * radius + 1) * (2 * radius + 1),
             0.0) {}

ColourMatrix LagCovariance::matrix(int vx, int vy) const {
    ColourMatrix m;
    m.n = m_channels;
    if (std::abs(vx) > m_radius || std::abs(vy) > m_radius) return m;
    for (int c = 0; c < m_channels; ++c)
        for (int d = 0; d < m_channels; ++d) m(c, d) = at(c, d, vx, vy);
    return m;
}

LagCovariance sampled_covariance(const Texton& t) {
    if (!valid_interpolation_order(t.order)) throw std::invalid_argument("bad texton order");
    const int r = t.size, nc = t.channels, n = 2 * r;
    // Cross-correlations A_cd(l) = sum_k alpha_c(k) alpha_d(k + l) by FFT on a 2r torus (no wrap).
    auto fft = RealFft2d::get(n, n);
    std::vector<Spectrum> spec;
    for (int c = 0; c < nc; ++c) {
        spec.emplace_back(n, n);
        fft->forward(t.alpha.plane(c), static_cast<std::size_t>(r), r, r, spec.back(), 1);
    }
    const int ra = r - 1;
    const int side = 2 * ra + 1;
    std::vector<double> corr(static_cast<std::size_t>(nc) * nc * side * side);
    std::vector<float> plane(static_cast<std::size_t>(n) * n);
    for (int c = 0; c < nc; ++c)
        for (int d = 0; d < nc; ++d) {
            Spectrum prod(n, n);
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < prod.cwidth(); ++j)
                    prod.row(i)[j] = std::conj(spec[static_cast<std::size_t>(c)].row(i)[j]) *
                                     spec[static_cast<std::size_t>(d)].row(i)[j];
            fft->inverse(prod, plane.data(), 1);
            const double inv = 1.0 / (static_cast<double>(n) * n);
            for (int ly = -ra; ly <= ra; ++ly)
                for (int lx = -ra; lx <= ra; ++lx)
                    corr[((static_cast<std::size_t>(c) * nc + d) * side + (ly + ra)) * side +
                         (lx + ra)] = plane[static_cast<std::size_t>((ly + n) % n) * n +
                                            static_cast<std::size_t>((lx + n) % n)] *
                                      inv;
        }
    // C = A * b (b separable, taps -order..order).
    const auto& taps = bspline_autocorrelation_taps(t.order);
    const int o = t.order, radius = ra + o;
    LagCovariance cov(radius, nc);
    for (int c = 0; c < nc; ++c)
        for (int d = 0; d < nc; ++d)
            for (int vy = -radius; vy <= radius; ++vy)
                for (int vx = -radius; vx <= radius; ++vx) {
                    double s = 0.0;
                    for (int ty = -o; ty <= o; ++ty)
                        for (int tx = -o; tx <= o; ++tx) {
                            const int ly = vy - ty, lx = vx - tx;
                            if (std::abs(lx) > ra || std::abs(ly) > ra) continue;
                            s += taps[static_cast<std::size_t>(ty + o)] *
                                 taps[static_cast<std::size_t>(tx + o)] *
                                 corr[((static_cast<std::size_t>(c) * nc + d) * side + (ly + ra)) *
                                          side +
                                      (lx + ra)];
                        }
                    cov.at(c, d, vx, vy) = s;
                }
    return cov;
}

ColourMatrix box_average_covariance(const LagCovariance& cov, std::int64_t st, int dx, int dy) {
    ColourMatrix m;
    m.n = cov.channels();
    const int R = cov.radius();
    const double s = static_cast<double>(st);
    auto weight = [&](int v, int d) {
        const double u = std::fabs(static_cast<double>(v) - s * d);
        return u < s ? s - u : 0.0;
    };
    std::vector<double> wx(static_cast<std::size_t>(2 * R + 1)), wy(wx.size());
    for (int v = -R; v <= R; ++v) {
        wx[static_cast<std::size_t>(v + R)] = weight(v, dx);
        wy[static_cast<std::size_t>(v + R)] = weight(v, dy);
    }
    const double norm = 1.0 / (s * s * s * s);
    for (int c = 0; c < m.n; ++c)
        for (int d = 0; d < m.n; ++d) {
            double acc = 0.0;
            for (int vy = -R; vy <= R; ++vy) {
                const double by = wy[static_cast<std::size_t>(vy + R)];
                if (by == 0.0) continue;
                double row = 0.0;
                for (int vx = -R; vx <= R; ++vx)
                    row += cov.at(c, d, vx, vy) * wx[static_cast<std::size_t>(vx + R)];
                acc += row * by;
            }
            m(c, d) = acc * norm;
        }
    return m;
}

CampbellMoments campbell_moments(const Texton& t) {
    if (t.order != 0 && t.order != 1)
        throw std::invalid_argument("campbell_moments: orders 0 and 1 only");
    CampbellMoments m;
    const int r = t.size;
    for (int c = 0; c < t.channels; ++c) {
        const auto ci = static_cast<std::size_t>(c);
        if (t.order == 0) {
            const float* a = t.alpha.plane(c);
            for (std::size_t k = 0; k < t.alpha.plane_size(); ++k) {
                const double v = a[k];
                m.h2[ci] += v * v;
                m.h4[ci] += v * v * v * v;
            }
            continue;
        }
        auto alpha = [&](int x, int y) -> double {
            return (x < 0 || y < 0 || x >= r || y >= r) ? 0.0 : t.alpha.at(c, x, y);
        };
        // Three-point Gauss-Legendre on [0, 1]: exact for degree 5 per axis (h^4 has degree 4).
        const double gx[3] = {0.5 - 0.5 * std::sqrt(0.6), 0.5, 0.5 + 0.5 * std::sqrt(0.6)};
        const double gw[3] = {5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0};
        for (int y = -1; y < r; ++y)
            for (int x = -1; x < r; ++x) {
                const double a00 = alpha(x, y), a10 = alpha(x + 1, y), a01 = alpha(x, y + 1),
                             a11 = alpha(x + 1, y + 1);
                if (a00 == 0.0 && a10 == 0.0 && a01 == 0.0 && a11 == 0.0) continue;
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j) {
                        const double u = gx[i], v = gx[j];
                        const double h = (1 - u) * (1 - v) * a00 + u * (1 - v) * a10 +
                                         (1 - u) * v * a01 + u * v * a11;
                        const double w = gw[i] * gw[j];
                        m.h2[ci] += w * h * h;
                        m.h4[ci] += w * h * h * h * h;
                    }
            }
    }
    return m;
}

} // namespace textond::core
