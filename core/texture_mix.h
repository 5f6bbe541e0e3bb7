#pragma once
// Texture mixing (texton-noise paper, section 7): optimal-transport barycentres of two Gaussian
// texture models, their textons at R levels of the mixing parameter rho, and the field rho(x)
// over the plane that picks a level for every Poisson point.
#include "core/gaussian_model.h"
#include "core/image.h"
#include "core/result.h"
#include "core/texton.h"
#include "core/texton_analysis.h"

#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <vector>

namespace textond::core {

inline constexpr const char* kMixVersion = "textond-mix/1";
inline constexpr int kDefaultMixLevels = 21; // the paper's R
inline constexpr int kMaxMixLevels = 64;

// The common grid of exemplars of these sizes: each side the smaller of the two, at most
// kWorkingSide (the centred window an analysis of a larger exemplar works on, for the same
// reason), brought down to a size FFTW transforms fast unless that is under `least`, the
// analysis' 2r (window_size, core/working_window.h; each of a mix's levels is an analysis on it).
std::array<int, 2> mix_grid(int uw, int uh, int vw, int vh, int least);

// Two models on one grid: both exemplars centre-cropped to mix_grid, a grey one promoted to RGB
// when the other is colour, each replaced by its periodic component when `periodic`.
struct ModelPair {
    GaussianModel u, v;
};
Result<ModelPair> common_models(const Image& u, const Image& v, bool periodic, int threads,
                                int least);

// Section 7: tau_rho = (1 - rho) tau_0 + rho t_v with tau_0^ = (t_u^* t_v^ / |t_u^* t_v^|) t_u^
// (one phase for all channels, the scalar sum_c conj(t_u^_c) t_v^_c; phase 1 where it is 0), and
// the mean (1 - rho) m_u + rho m_v. rho = 0 has u's spectrum modulus and colour covariance, rho = 1
// is v's model.
GaussianModel barycentre_model(const ModelPair& pair, double rho, int threads = 1);

struct MixLevels {
    std::vector<Texton> levels; // level l is rho = l / (R - 1)
    std::vector<double> rme;
};

// Textons of the R barycentres, each from the same white-noise start (params.seed) so that
// neighbouring levels are comparable (section 7); colour-corrected like any texton.
Result<MixLevels> mix_levels(const ModelPair& pair, const AnalysisParams& params, int levels,
                             const std::function<void(int, int)>& progress = {});

// rho(x) over the plane, x in texels. Ramp: rho = clamp(<x - origin, d> / width, 0, 1) with d the
// unit direction. Mask: a greyscale image (values in [0, 1]) whose pixel (i, j) covers texels
// origin + scale [i, i + 1) x [j, j + 1), sampled bilinearly at pixel centres, clamped at its
// edges.
struct MixField {
    enum class Kind { ramp, mask } kind = Kind::ramp;
    double x0 = 0, y0 = 0; // origin, texels
    double dx = 1, dy = 0; // ramp direction (normalised on use)
    double width = 1024;   // ramp width, texels
    double scale = 1;      // mask: texels per mask pixel
    Image mask;            // one channel

    double rho(double x, double y) const;
    std::optional<Error> validate() const;
};

// A decoded image as a mask field: its only channel, or the mean of its three, in [0, 1].
Image mask_from_image(const Image& image);

// The level of a point where the field is rho: round(rho (R - 1)), in [0, R - 1] for any rho,
// NaN (level 0) and infinities included: the result indexes the level tables.
inline int mix_level(double rho, int levels) {
    assert(levels >= 1 && !std::isnan(rho));
    const double v = rho * (levels - 1) + 0.5;
    if (!(v > 0.0)) return 0;                                  // NaN too: never cast NaN to int
    if (!(v < static_cast<double>(levels))) return levels - 1; // before the cast can overflow
    const int l = static_cast<int>(v);
    return l > levels - 1 ? levels - 1 : l;
}

} // namespace textond::core
