#pragma once
// Resampling of a periodic image to another size by its Fourier series (trigonometric
// interpolation): the result is again periodic, so a tileable texture stays tileable at any
// size. Frequencies above the smaller size's Nyquist limit are dropped (an ideal low-pass when
// shrinking); nothing is added when enlarging. RPN paper (TIP 2011), section 2: the DFT as the
// model of a periodic image.
#include "core/image.h"

namespace textond::core {

Image resample_periodic(const Image& in, int width, int height, int threads = 1);

} // namespace textond::core
