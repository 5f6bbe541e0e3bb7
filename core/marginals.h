#pragma once
// Marginal restoration: texton noise is Gaussian, many exemplars are not (dark gaps between
// pebbles, bright sparkles in sand). After Heitz and Neyret (HPG 2018, "High-performance by-example
// noise using a histogram-preserving blending operator", sections 1.3-1.4 and 4): the colours are
// decorrelated by PCA, and each component of the noise goes through a monotone table that maps
// its Gaussian marginal onto the exemplar's. The map is pointwise, so tiles stay seamless and
// deterministic. At zoomed-out levels the noise is box-averaged and its variance smaller; the
// table of level k is level 0's smoothed by a Gaussian of the variance the averaging removed, so
// a level's expected value equals level 0's (no darkening or sharpening when zooming out).
#include "core/colour_matrix.h"
#include "core/image.h"

#include <array>
#include <vector>

namespace textond::core {

// What the exemplar contributes (stored with the texton): its mean, a PCA basis of its colours and
// each component's quantiles.
struct MarginalModel {
    static constexpr int kQuantiles = 256; // at probabilities (i + 0.5) / kQuantiles
    int channels = 0;
    ChannelValues mean{};
    ColourMatrix basis;                          // columns: unit eigenvectors of C_u
    std::array<double, 3> variance{};            // each component's variance (eigenvalues)
    std::array<std::vector<float>, 3> quantiles; // of each centred component, ascending

    bool empty() const { return channels == 0; }
};

// PCA of u's colours and every component's quantiles (of u itself: no periodic component, the
// histogram is what the user sees).
MarginalModel marginal_model(const Image& u);

// The lookup tables for noise whose components have the given variances (level 0: the model's
// own; level k: those of the box-averaged field). Component i maps y to table(i, y).
class MarginalTables {
public:
    static constexpr int kEntries = 256; // over y / sigma in [-kRange, kRange]
    static constexpr double kRange = 6.0;

    MarginalTables() = default;
    // `level_variance`: the noise's variance along each basis vector at this level.
    MarginalTables(const MarginalModel& m, const std::array<double, 3>& level_variance);

    int channels() const { return m_channels; }
    // The restored value of one pixel (channels floats, in place).
    void apply(float* v) const;
    // Component i's table: kEntries values of T(y) at y = sigma (-kRange + 2 kRange j / (kEntries
    // - 1)); linear in between, clamped outside.
    const float* table(int i) const { return m_tables[static_cast<std::size_t>(i)].data(); }
    double sigma(int i) const { return m_sigma[static_cast<std::size_t>(i)]; }
    const ColourMatrix& basis() const { return m_basis; }
    const ChannelValues& mean() const { return m_mean; }
    // E[T(Y)] for Y ~ N(0, sigma^2): the level's expected value of component i (quadrature).
    double expected(int i) const;

private:
    int m_channels = 0;
    ColourMatrix m_basis;
    ChannelValues m_mean{};
    std::array<double, 3> m_sigma{};
    std::array<std::vector<float>, 3> m_tables;
    double lookup(int i, double y) const;
};

} // namespace textond::core
