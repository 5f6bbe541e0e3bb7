#pragma once
// Power spectra for people to look at (the quality panel of the web page): the exemplar's next to
// its texton noise's, on one logarithmic scale. RPN paper (TIP 2011), section 2: the Gaussian
// model of a texture is its power spectrum |t_u^|^2, so two images with the same model have the
// same spectrum up to sampling noise.
#include "core/image.h"

namespace textond::core {

// P(xi) = (1 / (C |Omega|)) sum_c |DFT(u_c - mean u_c)(xi)|^2 over the full frequency plane,
// with the zero frequency moved to the centre (pixel (W/2, H/2)); one channel.
Image centred_power_spectrum(const Image& u, int threads = 1);

// log10 of `p` mapped to [0, 1] so that `top` -> 1 and `top - decades` -> 0 (clamped). Use one
// `top` for spectra shown side by side.
Image log_display(const Image& p, double top, double decades);
double log10_max(const Image& p);

} // namespace textond::core
