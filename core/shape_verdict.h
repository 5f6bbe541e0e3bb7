#pragma once
// The micro/macro verdict: does the exemplar hold shapes that its Gaussian model, and so the
// texton, loses? Four statistics that a Gaussian texture does not control are measured on the
// exemplar and on K ADSN syntheses of its own model (Galerne, Gousseau and Morel, TIP 2011,
// Theorem 2: its spectrum with white-noise phases), and the verdict reads each one's excess over
// that per-exemplar null. What the spectrum alone does (a lattice of peaks from a repeated motif,
// a strong orientation, a box reduction that folds a period onto the Nyquist frequency) happens
// to the syntheses too, so it cancels; what the phases do does not.
//
//   tensor: anisotropy of the structure tensor, gradient at sigma 1 integrated at sigma 2:
//           sum sqrt((Jxx - Jyy)^2 + 4 Jxy^2) / sum (Jxx + Jyy). Edges, outlines, joints.
//   tv:     1 - TV / E[TV] of the image box-reduced by 4 (core/phase_coherence.h): sharp shapes
//           at the scale of a texture's parts.
//   lines:  log(kurtosis / 3) of an oriented line filter (derivative across at sigma 1, Gaussian
//           along at sigma 4), the largest of 4 orientations: long straight seams and grooves.
//   specks: log(kurtosis / 3) of the band sigma 1 minus sigma 2: isolated specks and grains,
//           which the noise blurs without a viewer naming a lost shape (its weight is negative).
//
// The statistics are in pixels of the exemplar box-reduced until its short side is under 512
// (a 1024 x 1024 analysis window by 4), of its grey level's periodic component; from 512 pixels
// on the short side, also of its centred part of that size at full resolution (kFineScaleOffset).
// core/README.md "Micro or macro" says how they, the weights and the offset were chosen, and how
// often they are right.
#include "core/image.h"
#include "core/phase_coherence.h"
#include "core/texture_kind.h"

#include <cstdint>
#include <vector>

namespace textond::core {

struct ShapeStatistics {
    double tensor = 0, tv = 0, lines = 0, specks = 0;
};

// Fitted on the fit set (the first corpus, tests/verdict/, and the fit half of the shapes corpus,
// tests/verdict/shapes/; logistic regression, balanced classes) by tests/verdict/fit_verdict.py:
// score = bias + sum of weight * excess. The score is the log-odds
// that a viewer names a shape the synthesis lost.
struct ShapeWeights {
    double bias, tensor, tv, lines, specks;
};
inline constexpr ShapeWeights kShapeWeights{-3.961463, 30.263934, 42.790682, 3.830087, -8.386317};
// From 512 pixels on the short side the verdict also measures the centred part of the exemplar
// at full resolution, as large as the reduced whole, where shapes a few pixels across are still
// shapes, and keeps the higher score of the two after taking this from the full resolution's:
// there photographed grain is sharp too. Chosen on the native sources of the first four
// corpora with the nine shared photos kept micro or macro (tests/verdict/fit_verdict.py
// --scales).
inline constexpr double kFineScaleOffset = 2.0;
// micro at or below -kShapeBand, macro above +kShapeBand, borderline between.
inline constexpr double kShapeBand = 0.25;

struct ShapeScale {
    int factor = 1;   // box reduction
    double score = 0; // the score of the image measured there
};

struct ShapeVerdict {
    ShapeStatistics exemplar;  // of the (reduced) exemplar
    ShapeStatistics null_mean; // mean over the ADSN syntheses
    ShapeStatistics null_sd;   // their standard deviation (sampling spread, for reference)
    ShapeStatistics excess;    // exemplar - null_mean
    double score = 0;          // log-odds of macro (less kFineScaleOffset when factor is 1 of 2)
    int factor = 1;            // box reduction before measuring
    int width = 0, height = 0; // the measured image
    std::vector<ShapeScale> scales; // each scale measured, coarsest first; the fields above: the
                                    // scale whose score (less its offset) is the higher
    TextureKind kind() const;
};

TextureKind shape_kind(double score);

inline constexpr int kShapeSamples = 8; // ADSN syntheses in the null

// Above this RME the texton misses its own model: the 95th percentile of the fit set's micro
// textures' RME (fit_verdict.py). The page and the quality report then never say that the noise
// keeps the exemplar's look, whatever the verdict.
inline constexpr double kMissedModelRme = 0.8467;

// Deterministic: the syntheses are seeded by `seed`, and every value is the same on any thread
// count. Images under 16 pixels a side have no excess measured: the bias alone (micro).
ShapeVerdict shape_verdict(const Image& u, int threads = 1, std::uint64_t seed = 0,
                           int samples = kShapeSamples);

} // namespace textond::core
