#include "core/gaussian_model.h"
#include "core/periodic_component.h"
#include "core/rme.h"
#include "core/texton_analysis.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

using namespace textond;
using namespace textond::core;

namespace {
GaussianModel sand_model(int w = 128, int h = 128) {
    return estimate_gaussian_model(
        periodic_component(test::crop(test::load_exemplar("etr_sand01.png"), w, h)));
}
} // namespace

TEST(Rme, OfTheModelKernelItselfIsZero) {
    const GaussianModel m = sand_model();
    // With the factor 2 of the OT distance this is 0; the paper's printed formula would give 1.
    EXPECT_LT(relative_model_error(m, m.t_u, 0), 2e-3);
}

TEST(Rme, OfAZeroKernelIsOne) {
    const GaussianModel m = sand_model();
    EXPECT_NEAR(relative_model_error(m, Image(16, 16, 3), 1), 1.0, 1e-9);
}

TEST(Rme, IsInvariantUnderTranslationOfTheKernel) {
    const GaussianModel m = sand_model();
    const Image alpha = alternating_projections(m, 32, 1, 20, 5, 1);
    const double r0 = relative_model_error(m, alpha, 1, 0, 0);
    EXPECT_GT(r0, 0.1);
    EXPECT_NEAR(relative_model_error(m, alpha, 1, 17, 5), r0, 1e-5);
    EXPECT_NEAR(relative_model_error(m, alpha, 1, 100, 121), r0, 1e-5); // wraps around
}

TEST(Rme, AccountsForTheBSplineOfTheInterpolationOrder) {
    // Coefficients made for order 1 fit the model as an order-1 texton, not as order 0 or 3.
    const GaussianModel m = sand_model();
    const Image alpha = alternating_projections(m, 32, 1, 30, 5, 1);
    const double as_order1 = relative_model_error(m, alpha, 1);
    EXPECT_LT(as_order1 + 0.05, relative_model_error(m, alpha, 0));
    EXPECT_LT(as_order1 + 0.05, relative_model_error(m, alpha, 3));
}
