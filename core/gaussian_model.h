#pragma once
// The Gaussian texture model of an exemplar (SOT paper, section 3.1, eq. (3)): mean colour m,
// kernel t_u = (u - m) / sqrt(|Omega|) with its DFT, and the colour covariance sum_x t_u t_u^T.
#include "core/colour_matrix.h"
#include "core/fft2d.h"
#include "core/image.h"

#include <array>
#include <vector>

namespace textond::core {

struct GaussianModel {
    int width = 0;
    int height = 0;
    int channels = 0;
    ChannelValues mean{};
    Image t_u;                   // planar, same size as the exemplar
    std::vector<Spectrum> t_hat; // one half spectrum per channel
    ColourMatrix covariance;     // = sum_x t_u(x) t_u(x)^T, the exemplar's colour covariance
};

// `u` should already be the periodic component when the model feeds FFT-based algorithms.
GaussianModel estimate_gaussian_model(const Image& u, int threads = 1);

// sum_x a_c(x) a_d(x) over two planes (double accumulation).
double plane_dot(const float* a, const float* b, std::size_t n);

} // namespace textond::core
