#pragma once
// Relative model error (SOT paper, section 3.2), with the factor 2 of the optimal transport
// distance (SOT eq. (1)) that the printed RME formula drops:
//   RME^2 = sum_xi (|t_u^|^2 + |k^|^2 - 2 |t_u^* k^|) / sum_xi |t_u^|^2,
// where k^ = alpha^ sqrt(b^) is the sampled kernel of an interpolated texton of the given order
// (texton-noise paper, eq. (4)) and t_u^* k^ = sum_c conj(t_u^_c) k^_c for colour.
#include "core/colour_matrix.h"
#include "core/gaussian_model.h"
#include "core/image.h"

#include <vector>

namespace textond::core {

// `kernel` (at most the model's size) is placed at (dx, dy) on the model's periodic domain.
double relative_model_error(const GaussianModel& model, const Image& kernel, int order, int dx = 0,
                            int dy = 0, int threads = 1);

// Same, from kernel spectra already multiplied by sqrt(b^).
double relative_model_error(const std::vector<Spectrum>& t_hat, const std::vector<Spectrum>& k_hat);

// Colour covariance of the texton noise of `alpha` (texton-noise paper, section 4.3, colour
// correction): sum_t b(t) sum_k alpha(k) alpha(k + t)^T, t over the B-spline taps.
ColourMatrix texton_noise_covariance(const Image& alpha, int order);

} // namespace textond::core
