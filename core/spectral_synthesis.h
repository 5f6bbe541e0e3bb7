#pragma once
// Spectral reference synthesis (Galerne, Gousseau, Morel, TIP 2011): ADSN (Theorem 2) and RPN
// (Definition 4) with one noise for all channels (section 5.1), at any output size through the
// spot extension with a smooth transition (section 5.3, eq. (4)).
#include "core/channels.h"
#include "core/fft2d.h"
#include "core/image.h"
#include "core/texton.h"

#include <array>
#include <cstdint>
#include <vector>

namespace textond::core {

enum class SpectralMethod { adsn, rpn };

// Normalised kernel for a width x height domain (sum of squares = model variance) from an
// exemplar's periodic component: p itself when the sizes match, else the spot extension
// t = (p - m) phi / sqrt(|R1|) centred in the domain, phi the smooth transition (alpha = 0.2).
Image spot_extension(const Image& periodic, const ChannelValues& mean, int width, int height,
                     double transition = 0.2);

// ADSN or RPN of the normalised kernel spectra k_hat on their periodic domain, plus `mean`.
// ADSN: Z^ = k^ W^ (W white Gaussian noise); RPN: Z^ = k^ sqrt(|domain|) e^{i theta}, theta a
// uniform random phase (the phase of W^). One noise for every channel keeps the colours.
Image spectral_synthesis(std::vector<Spectrum> k_hat, const ChannelValues& mean,
                         SpectralMethod method, std::uint64_t seed, int threads = 1);

// From an exemplar (takes its periodic component): any width x height (periodic output).
Image synthesize_from_exemplar(const Image& exemplar, SpectralMethod method, int width, int height,
                               std::uint64_t seed, int threads = 1);

// From a texton: the kernel alpha^ sqrt(b^) on a domain padded by r - 1, so the crop is the
// non-periodic ADSN/RPN of the texton (SOT paper, section 2.2).
Image synthesize_from_texton(const Texton& texton, SpectralMethod method, int width, int height,
                             std::uint64_t seed, int threads = 1);

} // namespace textond::core
