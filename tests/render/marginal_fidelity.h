#pragma once
// How faithful texton noise is to its exemplar with and without marginal restoration (the
// acceptance measures), shared by tests/bench/marginals_bench.cpp and render_stats_test.
#include "core/image.h"
#include "render/prepared_texton.h"

#include <memory>
#include <string>

namespace textond::test {

struct MarginalFidelity {
    // 1-D Wasserstein distance between the exemplar's and the noise's values along each of the
    // exemplar's principal colour directions, averaged over the directions.
    double w1_gaussian = 0, w1_exemplar = 0;
    // Power-spectrum RME (core/rme.h) between the exemplar's model and the noise window's.
    double rme_gaussian = 0, rme_exemplar = 0;
    double analysis_ms = 0;
};

// `exemplar` analysed (r = size, order 1, 50 iterations, seed 0), then `seeds` level-0 windows of
// the exemplar's size rendered on the CPU both ways; means over the seeds.
MarginalFidelity marginal_fidelity(const core::Image& exemplar, int size, int seeds);

// W1 between two samples, through 1000 quantiles of each.
double wasserstein1(std::vector<double> a, std::vector<double> b);

} // namespace textond::test
