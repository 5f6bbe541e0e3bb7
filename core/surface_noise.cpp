#include "core/surface_noise.h"

#include "core/grid_poisson.h"
#include "core/noise_hash.h"

#include <algorithm>
#include <cmath>

namespace textond::core {

using noise::absorb;
using noise::floor_div;
using noise::hi32;
using noise::lo32;
using noise::mix32;
using noise::Stream32;

void tangent_frame(const Vec3& n, Vec3& u1, Vec3& u2) {
    if (n[2] < -0.9999999) {
        u1 = {0.0, -1.0, 0.0};
        u2 = {-1.0, 0.0, 0.0};
        return;
    }
    const double a = 1.0 / (1.0 + n[2]);
    const double b = -n[0] * n[1] * a;
    u1 = {1.0 - n[0] * n[0] * a, b, -n[0]};
    u2 = {b, 1.0 - n[1] * n[1] * a, -n[1]};
}

std::uint32_t cell_key3(std::uint64_t seed, std::int64_t cx, std::int64_t cy, std::int64_t cz) {
    const auto ux = static_cast<std::uint64_t>(cx), uy = static_cast<std::uint64_t>(cy),
               uz = static_cast<std::uint64_t>(cz);
    std::uint32_t k = mix32(lo32(seed) ^ 0x3c6ef372u);
    k = absorb(k, hi32(seed));
    k = absorb(k, lo32(ux));
    k = absorb(k, hi32(ux));
    k = absorb(k, lo32(uy));
    k = absorb(k, hi32(uy));
    k = absorb(k, lo32(uz));
    return absorb(k, hi32(uz));
}

SurfaceNoise::SurfaceNoise(const Texton& texton, double mni)
    : m_t(texton), m_a(noise::cell_size(texton.size)) {
    const double r = texton.size;
    m_lambda = mni / (r * r * r); // Prop. 3: MNI = lambda r^3
    m_norm = 1.0 / std::sqrt(m_lambda * r / 3.0);
    m_thresholds = noise::poisson_thresholds(m_lambda * m_a * m_a * m_a);
}

void SurfaceNoise::h(double z1, double z2, double* v) const {
    // The texton centred on the origin: its coefficients span [0, r - 1], so shift by (r - 1)/2.
    const double shift = 0.5 * (m_t.size - 1);
    const double x = z1 + shift, y = z2 + shift;
    const int r = m_t.size, nc = m_t.channels;
    for (int c = 0; c < nc; ++c) v[c] = 0.0;
    const double fx = std::floor(x), fy = std::floor(y);
    const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
    // Taps: order 0 one, order 1 two (ix, ix + 1), order 3 four (ix - 1 .. ix + 2) per axis.
    double wx[4] = {1, 0, 0, 0}, wy[4] = {1, 0, 0, 0};
    int n = 1, first = 0;
    const double tx = x - fx, ty = y - fy;
    if (m_t.order == 1) {
        n = 2;
        wx[0] = 1 - tx;
        wx[1] = tx;
        wy[0] = 1 - ty;
        wy[1] = ty;
    } else if (m_t.order == 3) {
        n = 4;
        first = -1;
        auto w = [](double t, double out[4]) {
            const double s = 1 - t;
            out[0] = s * s * s / 6;
            out[1] = (3 * t * t * t - 6 * t * t + 4) / 6;
            out[2] = (3 * s * s * s - 6 * s * s + 4) / 6;
            out[3] = t * t * t / 6;
        };
        w(tx, wx);
        w(ty, wy);
    }
    for (int j = 0; j < n; ++j) {
        const int yy = iy + first + j;
        if (yy < 0 || yy >= r) continue;
        for (int i = 0; i < n; ++i) {
            const int xx = ix + first + i;
            if (xx < 0 || xx >= r) continue;
            const double w = wy[j] * wx[i];
            for (int c = 0; c < nc; ++c) v[c] += w * m_t.alpha.at(c, xx, yy);
        }
    }
}

// Calls f(eps w, z1, z2) for every point of the process that reaches y (normal n, frame u1, u2),
// in the process's order.
template <typename F>
void SurfaceNoise::for_each_impact(std::uint64_t seed, const Vec3& y, const Vec3& n, const Vec3& u1,
                                   const Vec3& u2, SurfaceStats* stats, F&& f) const {
    const int r = m_t.size;
    const double half = 0.5 * r;
    // Every point within the r-cube around y lies within r sqrt(3) / 2 of y, and the texton's
    // support (with its interpolation) within r/2 + 2 of the centre in each tangent direction.
    const double reach = std::sqrt(3.0) * (half + 2.0);
    std::int64_t lo[3], hi[3];
    for (int d = 0; d < 3; ++d) {
        lo[d] = floor_div(
            static_cast<std::int64_t>(std::floor(y[static_cast<std::size_t>(d)] - reach)), m_a);
        hi[d] = floor_div(
            static_cast<std::int64_t>(std::floor(y[static_cast<std::size_t>(d)] + reach)), m_a);
    }
    const auto ua = static_cast<std::uint64_t>(m_a);
    for (std::int64_t cz = lo[2]; cz <= hi[2]; ++cz)
        for (std::int64_t cy = lo[1]; cy <= hi[1]; ++cy)
            for (std::int64_t cx = lo[0]; cx <= hi[0]; ++cx) {
                Stream32 s(cell_key3(seed, cx, cy, cz));
                const int count = noise::poisson_count(
                    m_thresholds.data(), static_cast<int>(m_thresholds.size()), s.next());
                const std::int64_t cell[3] = {cx, cy, cz};
                for (int i = 0; i < count; ++i) {
                    Vec3 d; // y - x_i
                    for (int k = 0; k < 3; ++k) {
                        const std::uint64_t p = s.next() * ua;
                        const double x = static_cast<double>(cell[k] * m_a +
                                                             static_cast<std::int64_t>(p >> 32)) +
                                         static_cast<double>((p & 0xffffffffu) >> 8) / 16777216.0;
                        d[static_cast<std::size_t>(k)] = y[static_cast<std::size_t>(k)] - x;
                    }
                    const double eps = (s.next() >> 31) == 0 ? 1.0 : -1.0;
                    if (stats) ++stats->points;
                    const double t = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
                    const double w = 1.0 - 2.0 * std::fabs(t) / r;
                    if (w <= 0) continue;
                    const double z1 = d[0] * u1[0] + d[1] * u1[1] + d[2] * u1[2];
                    const double z2 = d[0] * u2[0] + d[1] * u2[1] + d[2] * u2[2];
                    if (stats && std::fabs(z1) < half && std::fabs(z2) < half) ++stats->impacts;
                    if (std::fabs(z1) >= half + 2.0 || std::fabs(z2) >= half + 2.0) continue;
                    f(eps * w, z1, z2);
                }
            }
}

void SurfaceNoise::eval(std::uint64_t seed, const Vec3& y, const Vec3& n, float* out,
                        SurfaceStats* stats) const {
    Vec3 u1, u2;
    tangent_frame(n, u1, u2);
    const int nc = std::min(m_t.channels, 3); // 1 or 3 (checked at load)
    double acc[3] = {0, 0, 0};
    for_each_impact(seed, y, n, u1, u2, stats, [&](double ew, double z1, double z2) {
        double v[3] = {0, 0, 0};
        h(z1, z2, v);
        for (int c = 0; c < nc; ++c) acc[c] += ew * v[c];
    });
    for (int c = 0; c < nc; ++c)
        out[c] = static_cast<float>(m_t.mean[static_cast<std::size_t>(c)] + m_norm * acc[c]);
}

// The weights' derivatives: d/dz of h's taps (order 1: the two linear weights; order 3: the cubic
// B-spline's quadratic derivative); order 0 has none.
void SurfaceNoise::dh(double z1, double z2, double g[2]) const {
    const double shift = 0.5 * (m_t.size - 1);
    const double x = z1 + shift, y = z2 + shift;
    const int r = m_t.size;
    const double fx = std::floor(x), fy = std::floor(y);
    const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
    const double tx = x - fx, ty = y - fy;
    double wx[4] = {0, 0, 0, 0}, wy[4] = {0, 0, 0, 0}, dx[4] = {0, 0, 0, 0}, dy[4] = {0, 0, 0, 0};
    int n = 0, first = 0;
    if (m_t.order == 1) {
        n = 2;
        wx[0] = 1 - tx, wx[1] = tx, dx[0] = -1, dx[1] = 1;
        wy[0] = 1 - ty, wy[1] = ty, dy[0] = -1, dy[1] = 1;
    } else if (m_t.order == 3) {
        n = 4;
        first = -1;
        auto w = [](double t, double v[4], double d[4]) {
            const double s = 1 - t;
            v[0] = s * s * s / 6;
            v[1] = (3 * t * t * t - 6 * t * t + 4) / 6;
            v[2] = (3 * s * s * s - 6 * s * s + 4) / 6;
            v[3] = t * t * t / 6;
            d[0] = -s * s / 2;
            d[1] = (3 * t * t - 4 * t) / 2;
            d[2] = (4 * s - 3 * s * s) / 2;
            d[3] = t * t / 2;
        };
        w(tx, wx, dx);
        w(ty, wy, dy);
    }
    g[0] = g[1] = 0.0;
    for (int j = 0; j < n; ++j) {
        const int yy = iy + first + j;
        if (yy < 0 || yy >= r) continue;
        for (int i = 0; i < n; ++i) {
            const int xx = ix + first + i;
            if (xx < 0 || xx >= r) continue;
            const double a = m_t.alpha.at(0, xx, yy);
            g[0] += wy[j] * dx[i] * a;
            g[1] += dy[j] * wx[i] * a;
        }
    }
}

Vec3 SurfaceNoise::gradient(std::uint64_t seed, const Vec3& y, const Vec3& n) const {
    Vec3 u1, u2;
    tangent_frame(n, u1, u2);
    double g[2] = {0, 0};
    for_each_impact(seed, y, n, u1, u2, nullptr, [&](double ew, double z1, double z2) {
        double d[2];
        dh(z1, z2, d);
        g[0] += ew * d[0];
        g[1] += ew * d[1];
    });
    // z moves with y along the frame and w does not (u1, u2 are orthogonal to n).
    Vec3 out;
    for (std::size_t k = 0; k < 3; ++k) out[k] = m_norm * (g[0] * u1[k] + g[1] * u2[k]);
    return out;
}

} // namespace textond::core
