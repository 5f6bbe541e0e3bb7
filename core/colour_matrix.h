#pragma once
// Small symmetric matrices (one entry per channel pair, up to 8x8) and the square roots the
// colour correction needs. Double precision: these are sums over a whole image.
#include "core/channels.h"

#include <array>

namespace textond::core {

struct ColourMatrix {
    int n = 0; // 1 (grey), 3 (RGB) or a material set's channels, at most kMaxChannels
    std::array<std::array<double, kMaxChannels>, kMaxChannels> m{};

    double& operator()(int i, int j) {
        return m[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
    }
    double operator()(int i, int j) const {
        return m[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
    }
};

ColourMatrix multiply(const ColourMatrix& a, const ColourMatrix& b);
ColourMatrix transpose(const ColourMatrix& a);
double max_abs_difference(const ColourMatrix& a, const ColourMatrix& b);
double max_abs(const ColourMatrix& a);

// Symmetric eigen-decomposition (cyclic Jacobi): a = v diag(w) v^T.
void symmetric_eigen(const ColourMatrix& a, ChannelValues& w, ColourMatrix& v);

// Symmetric square root of a positive semi-definite matrix (negative round-off clipped to 0).
ColourMatrix sqrt_psd(const ColourMatrix& a);
// Moore-Penrose pseudo-inverse of sqrt_psd(a): eigenvalues below rel_tol * the largest count as 0,
// so a grey image stored as RGB (rank 1) or a constant channel does not blow up.
ColourMatrix pinv_sqrt_psd(const ColourMatrix& a, double rel_tol = 1e-9);

} // namespace textond::core
