#pragma once
// Linear filters applied on a half spectrum (core/fft2d.h): a transfer function is sampled once
// for an image size, then multiplies any spectrum of that size. The micro/macro verdict filters
// the exemplar and each of its null syntheses with the same ones (core/shape_verdict.cpp).
#include "core/fft2d.h"

#include <cstddef>
#include <vector>

namespace textond::core {

// A transfer function's value on each bin of a half spectrum, row by row.
using Transfer = std::vector<cfloat>;

// Angular frequency (radians a pixel) of row or column k of a spectrum n bins long.
double angular_frequency(int k, int n);

// A Gaussian of standard deviation sigma pixels, in frequency: exp(-sigma^2 |w|^2 / 2).
double gaussian_response(double wx, double wy, double sigma);

// h(wx, wy) sampled on the half spectrum of a w x h image.
template <typename H> Transfer sampled_transfer(int w, int h, H transfer) {
    const int cw = w / 2 + 1;
    Transfer t(static_cast<std::size_t>(cw) * h);
    for (int i = 0; i < h; ++i) {
        const double wy = angular_frequency(i, h);
        for (int j = 0; j < cw; ++j)
            t[static_cast<std::size_t>(i) * cw + j] = transfer(angular_frequency(j, w), wy);
    }
    return t;
}

// The image whose spectrum is spec times t (spec is left intact).
std::vector<float> filtered(const Spectrum& spec, const RealFft2d& fft, int threads,
                            const Transfer& t);
// A field filtered by t (periodic): its spectrum, times t, back.
std::vector<float> filtered(const std::vector<float>& field, const RealFft2d& fft, int threads,
                            const Transfer& t);

// Anisotropy of the structure tensor of the gradient (gx, gy), integrated over `window` (a
// Gaussian's transfer): sum sqrt((Jxx - Jyy)^2 + 4 Jxy^2) / sum (Jxx + Jyy), 0 for a flat field.
double structure_tensor_anisotropy(const std::vector<float>& gx, const std::vector<float>& gy,
                                   const RealFft2d& fft, int threads, const Transfer& window);

// A filtered field's skewness and log(kurtosis / 3), 0 for a Gaussian field's; both 0 for a
// flat one.
struct BandMoments {
    double skew = 0, log_kurtosis = 0;
};
BandMoments band_moments(const std::vector<float>& field);

} // namespace textond::core
