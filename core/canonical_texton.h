#pragma once
// Canonical texton (Desolneux, Moisan, Ronsin, ICASSP 2012): the image with the model's Fourier
// modulus and a null phase (Definition 1); for colour, every channel loses the phase of the
// luminance (1/3, 1/2, 1/6) . u (Proposition 2), which keeps the phase differences between
// channels. Cropped to r x r it is the baseline the SOT is compared with (SOT paper, Fig. 4).
#include "core/gaussian_model.h"
#include "core/texton.h"

namespace textond::core {

// Canonical texton of the spectral target t_u^ / sqrt(b^) for the given interpolation order
// (order 0: the ICASSP texton of t_u itself), full size, centred at pixel (0, 0).
Image canonical_texton(const GaussianModel& model, int order, int threads = 1);

// Its r x r crop centred on the origin, as texton coefficients (no colour correction).
Texton cropped_canonical_texton(const GaussianModel& model, int size, int order, int threads = 1);

} // namespace textond::core
