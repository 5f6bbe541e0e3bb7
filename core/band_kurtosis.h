#pragma once
// Non-Gaussianity of band-pass responses, for the micro/macro verdict. A Gaussian
// texture's response to any linear filter is Gaussian, so its kurtosis E[b^4] / E[b^2]^2 is 3:
// shapes move it away from 3, above for sparse edges and spots, below for regular shapes (rings,
// tiles). A finite image's kurtosis is 3 only on average, so each band's is compared with the
// same band of random-phase versions of the exemplar (RPN paper, section 3: the same spectrum,
// uniform random phases), which share its spectrum and so its sampling spread.
#include "core/image.h"

#include <cstdint>
#include <vector>

namespace textond::core {

struct BandKurtosis {
    double sigma = 0;        // the band: Gaussian blur at sigma minus blur at 2 sigma, in pixels
    double kurtosis = 0;     // of the exemplar's band
    double random_phase = 0; // mean over the random-phase versions
    double log_ratio = 0;    // log(kurtosis / random_phase): 0 for a Gaussian texture
};

// Of the grey level (the channels' mean) of `u`, which should be periodic (its periodic
// component): the bands sigma = 1, 2, 4, ... while 4 sigma fits in the short side / 4, with
// `samples` random-phase versions drawn from `seed`.
std::vector<BandKurtosis> band_kurtosis(const Image& u, int samples = 4, std::uint64_t seed = 0,
                                        int threads = 1);

} // namespace textond::core
