#pragma once
// Exemplar -> texton: periodic component, Gaussian model, alternating projections (texton-noise
// paper Algorithm 1 with the colour projection of section 4.3; SOT paper Algorithm 2), colour
// correction, RME.
#include "core/colour_matrix.h"
#include "core/gaussian_model.h"
#include "core/phase_coherence.h"
#include "core/result.h"
#include "core/shape_verdict.h"
#include "core/texton.h"
#include "core/working_window.h"

#include <cstdint>
#include <functional>
#include <optional>

namespace textond::core {

// Part of every texton id: bump when any step below changes its output.
inline constexpr const char* kAnalysisVersion = "textond-analysis/1";

struct AnalysisParams {
    int size = 64;       // r: texton support r x r, 8..256 and at most half the short side
    int order = 1;       // interpolation order 0, 1 or 3
    int iterations = 50; // alternating projections, 1..1000
    std::uint64_t seed = 0;
    bool periodic = true; // replace the exemplar by its periodic component first
    int threads = 0;      // 0 = all cores; results are bit-identical for any value
    // Past this many pixels a side the centred window stands for the exemplar in the model,
    // the projections and the RME (core/working_window.h); 0: the whole exemplar (benchmarks).
    int working_side = kWorkingSide;
};

struct AnalysisTimings {
    double periodic_ms = 0, model_ms = 0, projections_ms = 0, correction_ms = 0, rme_ms = 0,
           total_ms = 0;
    // The phase coherence (for reference), the micro/macro verdict, the kept marginals.
    double coherence_ms = 0, shape_ms = 0, marginals_ms = 0;
};

struct AnalysisResult {
    Texton texton;              // colour-corrected coefficients
    double rme = 0;             // of the corrected texton (what we report)
    double rme_uncorrected = 0; // before the colour correction (lower, wrong contrast)
    ColourMatrix correction;    // the matrix applied
    AnalysisTimings timings;
    // Of the exemplar: will the texton keep its look (micro) or lose its shapes (macro)? The
    // verdict is `shape`'s; `coherence` is kept for reference. None for a model given directly
    // (texture mixing's barycentres).
    std::optional<PhaseCoherence> coherence;
    std::optional<ShapeVerdict> shape;
};

// (done, total) after each projection; may be called from the analysing thread only.
using ProgressFn = std::function<void(int, int)>;

std::optional<Error> validate_analysis(const AnalysisParams& params, int width, int height,
                                       int channels);

Result<AnalysisResult> analyze_texton(const Image& exemplar, const AnalysisParams& params,
                                      const ProgressFn& progress = {});

// The steps after the model (projections, colour correction, RME) for a model given directly:
// the texture mixing's barycentres (texton-noise section 7). `params.periodic` is not used.
AnalysisResult texton_from_model(const GaussianModel& model, const AnalysisParams& params,
                                 const ProgressFn& progress = {});

// Texton-noise paper Algorithm 1 (colour projection of section 4.3): coefficients supported on
// [0, size)^2 whose spectrum times sqrt(b^) approaches |t_u^|, from a seeded random phase.
Image alternating_projections(const GaussianModel& model, int size, int order, int iterations,
                              std::uint64_t seed, int threads, const ProgressFn& progress = {});

// A with A C_alpha A^T = C_u: A = C_u^{1/2} pinv(C_alpha^{1/2}) (symmetric roots; pseudo-inverse
// so that rank-deficient colour, e.g. grey stored as RGB, stays finite). For one channel this is
// the scalar variance correction sqrt(C_u / C_alpha).
ColourMatrix colour_correction_matrix(const ColourMatrix& c_u, const ColourMatrix& c_alpha);
void apply_colour_matrix(Image& alpha, const ColourMatrix& a);

} // namespace textond::core
