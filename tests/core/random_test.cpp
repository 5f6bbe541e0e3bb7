#include "core/random.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using textond::core::Rng;

TEST(Rng, SameSeedSameStreamDifferentSeedDifferentStream) {
    Rng a(42), b(42), c(43);
    for (int i = 0; i < 100; ++i) {
        const auto x = a.next_u64();
        EXPECT_EQ(x, b.next_u64());
        EXPECT_NE(x, c.next_u64());
    }
}

TEST(Rng, NormalHasUnitVarianceAndZeroKurtosis) {
    Rng rng(7);
    const int n = 400000;
    double s = 0, s2 = 0, s4 = 0;
    for (int i = 0; i < n; ++i) {
        const double v = rng.normal();
        s += v;
        s2 += v * v;
        s4 += v * v * v * v;
    }
    const double mean = s / n, var = s2 / n - mean * mean;
    // Standard errors: 1/sqrt(n) for the mean, sqrt(2/n) for the variance, sqrt(24/n) for kurtosis.
    EXPECT_NEAR(mean, 0.0, 5.0 / std::sqrt(n));
    EXPECT_NEAR(var, 1.0, 5.0 * std::sqrt(2.0 / n));
    EXPECT_NEAR(s4 / n / (var * var) - 3.0, 0.0, 5.0 * std::sqrt(24.0 / n));
}

TEST(Rng, PoissonMatchesMeanAndVarianceAtSmallAndLargeMeans) {
    for (double lambda : {0.05, 1.0, 11.7, 78.0, 3000.0}) {
        Rng rng(static_cast<std::uint64_t>(lambda * 1000));
        const int n = 100000;
        double s = 0, s2 = 0;
        for (int i = 0; i < n; ++i) {
            const double k = static_cast<double>(rng.poisson(lambda));
            s += k;
            s2 += k * k;
        }
        const double mean = s / n, var = s2 / n - mean * mean;
        // Var of the sample mean: lambda/n; of the sample variance: (2 lambda^2 + lambda)/n.
        EXPECT_NEAR(mean, lambda, 5.0 * std::sqrt(lambda / n)) << lambda;
        EXPECT_NEAR(var, lambda, 5.0 * std::sqrt((2 * lambda * lambda + lambda) / n)) << lambda;
    }
}

TEST(Rng, PoissonZeroMeanIsZeroAndBelowIsInRange) {
    Rng rng(1);
    EXPECT_EQ(rng.poisson(0.0), 0u);
    EXPECT_THROW(rng.poisson(-1.0), std::invalid_argument);
    std::vector<int> hist(7, 0);
    for (int i = 0; i < 70000; ++i) ++hist[rng.below(7)];
    for (int h : hist) EXPECT_NEAR(h, 10000, 5 * std::sqrt(10000.0 * 6 / 7));
}
