#pragma once
// Second- and fourth-order statistics of texton noise, from the texton alone.
//   C(v) = integral h(y) h(y + v)^T dy = sum_l (alpha~ * alpha)(l) b(v - l)   (texton-noise eq.
//   (4))
// is the covariance of the normalised noise at integer lags v; Campbell's theorem gives the
// variance integral h^2 and the fourth cumulant integral h^4 / lambda of each channel.
#include "core/colour_matrix.h"
#include "core/texton.h"

#include <array>
#include <cstdint>
#include <vector>

namespace textond::core {

// C(v) for v in [-radius, radius]^2 (radius = r - 1 + order: zero beyond).
class LagCovariance {
public:
    LagCovariance() = default;
    LagCovariance(int radius, int channels);
    int radius() const { return m_radius; }
    int channels() const { return m_channels; }
    double& at(int c, int d, int vx, int vy) { return m_data[index(c, d, vx, vy)]; }
    double at(int c, int d, int vx, int vy) const { return m_data[index(c, d, vx, vy)]; }
    ColourMatrix matrix(int vx, int vy) const;

private:
    std::size_t index(int c, int d, int vx, int vy) const {
        const int n = 2 * m_radius + 1;
        return ((static_cast<std::size_t>(c) * m_channels + d) * n + (vy + m_radius)) * n +
               (vx + m_radius);
    }
    int m_radius = 0;
    int m_channels = 0;
    std::vector<double> m_data;
};

LagCovariance sampled_covariance(const Texton& texton);

// Covariance between two pixels D apart of the st x st box average of the field:
// (1/st^4) sum_v C(v) (st - |v1 - st D1|)+ (st - |v2 - st D2|)+ (NOISE_SPEC.md section 6).
ColourMatrix box_average_covariance(const LagCovariance& cov, std::int64_t st, int dx, int dy);

struct CampbellMoments {
    ChannelValues h2{}; // integral of h_c^2: the variance of channel c
    ChannelValues h4{}; // integral of h_c^4
    // Excess kurtosis of channel c at intensity lambda: h4 / (lambda h2^2).
    double excess_kurtosis(int c, double lambda) const {
        const auto i = static_cast<std::size_t>(c);
        return h2[i] > 0.0 ? h4[i] / (lambda * h2[i] * h2[i]) : 0.0;
    }
};

// Exact integrals of the continuous texton (orders 0 and 1): Gauss-Legendre on every unit square,
// exact for the bilinear pieces.
CampbellMoments campbell_moments(const Texton& texton);

} // namespace textond::core
