#pragma once
// Phase coherence of an exemplar: the sharpness index of Leclaire and Moisan (JMIV 2015, "No-
// reference image quality assessment and blind deblurring with sharpness metrics exploiting
// Fourier phase information", section 3). The total variation of the image is compared with its
// distribution when the phases are made random (the Gaussian texture u * W that a texton
// reproduces): a micro-texture's TV is typical of that distribution, while edges and shapes
// (phase coherence) make it far smaller. The index is -log10 of the probability that the random
// phase image has a TV as small.
#include "core/image.h"
#include "core/texture_kind.h"

#include <vector>

namespace textond::core {

struct SharpnessIndex {
    double index = 0;     // SI = -log10 Phi((mean - tv) / sd); 0 for a flat image
    double tv = 0;        // TV(u): sum of |periodic finite differences| over x and y
    double mean = 0;      // E[TV(u * W)], closed form (section 3.2)
    double sd = 0;        // its standard deviation, closed form (section 3.2)
    double deviation = 0; // (mean - tv) / sd, in standard deviations
};

// Of the grey level (the channels' mean) of u's periodic component (Moisan 2011), so the border
// does not count as an edge; of u itself when `periodic` says u is periodic already. Leclaire and
// Moisan, section 3.2 (Theorem 2): with W white Gaussian noise and the gradients' auto- and
// cross-correlations computed by FFT,
//   mean = sqrt(2 MN / pi) (|dx u| + |dy u|),
//   var  = (2/pi) sum_z [a^2 w(rxx(z)) + b^2 w(ryy(z)) + 2ab w(rxy(z))],
// with w(t) = t asin(t) + sqrt(1 - t^2) - 1, a = |dx u|, b = |dy u| and r the correlations.
SharpnessIndex sharpness_index(const Image& u, int threads = 1, bool periodic = false);

// The grey level of u: one plane, the mean of its channels.
Image grey_level(const Image& u);

// Box average over f x f blocks (the remainder rows and columns dropped), every channel.
Image box_reduce(const Image& u, int f);
// box_reduce of u's centred part whose reduced sides are fast FFT sizes (fast_side, at least
// `least`; core/working_window.h): a fast window reduced by 2 or 3 is often not fast (675 / 2 =
// 337, a prime), and the shape verdict transforms the reduced image once per null sample. u
// itself, reduced as box_reduce does, where its reduced sides are fast already.
Image fast_box_reduce(const Image& u, int f, int least = 16);

// The micro/macro verdict. SI alone does not separate the shared photos (README, "Micro or
// macro"): it grows with the image's size and is dominated by the finest scale, where grain,
// JPEG blocks and palettes count as sharpness. What a texton loses is coherence at the scale of
// shapes, so the exemplar is box-reduced until its short side is about 128, 64 and 32 pixels, and
// at each scale the TV is compared with its random-phase mean: coherence = 1 - TV / E[TV], which
// does not grow with the image's size (0 for a random-phase image, give or take sd / E[TV]).
// The index is the mean over those scales.
// 1 - TV / E[TV] of a sharpness index: 0 for a flat image (no random-phase mean).
double coherence_of(const SharpnessIndex& si);

struct CoherenceScale {
    int factor = 1; // box reduction factor
    int width = 0, height = 0;
    double coherence = 0; // 1 - tv / mean at this scale
    SharpnessIndex si;
};

struct PhaseCoherence {
    double index = 0;    // mean coherence over the scales
    SharpnessIndex full; // SI of the exemplar at its own size, for reference
    std::vector<CoherenceScale> scales;
    TextureKind kind() const;
    bool macro() const { return kind() == TextureKind::macro; }
};

// The first verdict's thresholds on this index alone, which the shape verdict replaced
// (core/shape_verdict.h: kShapeWeights, kShapeBand). They still read texton files written
// before it, whose metadata holds only the index (api/texton_meta.cpp). Chosen on the fit half of
// the first corpus (tests/verdict/corpus.tsv, 104 textures), best threshold 0.0617, borderline
// band +- 25%.
inline constexpr double kMicroCoherence = 0.046; // at most: micro
inline constexpr double kMacroCoherence = 0.077; // above: macro; between: borderline
TextureKind texture_kind(double index);

// Scales whose short side is at least 32 (one scale, the image itself, below that).
PhaseCoherence phase_coherence(const Image& u, int threads = 1);

// -log10 Phi(x) for the standard normal distribution function Phi, without underflow far in
// the lower tail (the asymptotic series below x = -30, where erfc leaves double's range).
double minus_log10_phi(double x);

} // namespace textond::core
