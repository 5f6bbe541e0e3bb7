#include "core/gaussian_model.h"
#include "core/periodic_component.h"
#include "core/spectral_synthesis.h"
#include "core/texton_analysis.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace textond;
using namespace textond::core;

namespace {
const int kN = 64;
Image sand64() {
    return test::crop(test::load_exemplar("etr_sand01.png"), kN, kN);
}
} // namespace

TEST(Adsn, AveragedPeriodogramMatchesTheModelSpectrum) {
    const Image u = sand64();
    const GaussianModel m = estimate_gaussian_model(periodic_component(u));
    const int seeds = 64;
    const int cw = kN / 2 + 1;
    std::vector<double> avg(static_cast<std::size_t>(kN) * cw, 0.0);
    const auto fft = RealFft2d::get(kN, kN);
    for (int s = 0; s < seeds; ++s) {
        const Image z = synthesize_from_exemplar(u, SpectralMethod::adsn, kN, kN, s);
        Spectrum zs(kN, kN);
        std::vector<float> centred(z.plane_size());
        for (std::size_t k = 0; k < z.plane_size(); ++k)
            centred[k] = z.plane(0)[k] - static_cast<float>(m.mean[0]);
        fft->forward(centred.data(), zs, 1);
        for (int i = 0; i < kN; ++i)
            for (int j = 0; j < cw; ++j)
                avg[static_cast<std::size_t>(i) * cw + j] +=
                    std::norm(zs.row(i)[j]) / (kN * kN) / seeds;
    }
    // Each periodogram value over the model is Exp(1); the mean of `seeds` of them has variance
    // 1/seeds. Over the independent frequencies (interior columns), the normalised squared error
    // seeds*(ratio-1)^2 averages to 1 with a spread of about sqrt(2/count) (+ Gamma skew).
    double sum_ratio = 0, sum_sq = 0;
    int count = 0;
    for (int i = 0; i < kN; ++i)
        for (int j = 1; j < cw - 1; ++j) {
            const double model = std::norm(m.t_hat[0].row(i)[j]);
            if (model < 1e-12) continue;
            const double ratio = avg[static_cast<std::size_t>(i) * cw + j] / model;
            sum_ratio += ratio;
            sum_sq += seeds * (ratio - 1) * (ratio - 1);
            ++count;
        }
    ASSERT_GT(count, 1500);
    EXPECT_NEAR(sum_ratio / count, 1.0, 5.0 / std::sqrt(double(count) * seeds));
    EXPECT_NEAR(sum_sq / count, 1.0, 5.0 * std::sqrt(2.5 / count));
}

TEST(Rpn, ModulusEqualsTheModelExactlyAndTheMeanIsKept) {
    const Image u = sand64();
    const GaussianModel m = estimate_gaussian_model(periodic_component(u));
    const Image z = synthesize_from_exemplar(u, SpectralMethod::rpn, kN, kN, 3);
    const GaussianModel mz = estimate_gaussian_model(z);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(mz.mean[c], m.mean[c], 1e-5);
        for (int i = 0; i < kN; ++i)
            for (int j = 0; j < kN / 2 + 1; ++j)
                ASSERT_NEAR(std::abs(mz.t_hat[c].row(i)[j]), std::abs(m.t_hat[c].row(i)[j]),
                            2e-5 + 1e-4 * std::abs(m.t_hat[c].row(i)[j]));
    }
}

TEST(Adsn, KeepsTheMeanExactly) {
    const Image u = sand64();
    const GaussianModel m = estimate_gaussian_model(periodic_component(u));
    const GaussianModel mz =
        estimate_gaussian_model(synthesize_from_exemplar(u, SpectralMethod::adsn, kN, kN, 8));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(mz.mean[c], m.mean[c], 1e-5);
}

TEST(SpotExtension, AnyOutputSizeKeepsVarianceAndWrapsWithoutASeam) {
    const Image u = sand64();
    const GaussianModel m = estimate_gaussian_model(periodic_component(u));
    const Image z = synthesize_from_exemplar(u, SpectralMethod::rpn, 150, 90, 4);
    ASSERT_EQ(z.width, 150);
    ASSERT_EQ(z.height, 90);
    // RPN keeps the extended kernel's energy exactly (Parseval), and the extension keeps the
    // model variance up to the transition's weighting of the spot (centre over border): 15%.
    const Image t = spot_extension(periodic_component(u), m.mean, 150, 90);
    const GaussianModel mz = estimate_gaussian_model(z);
    for (int c = 0; c < 3; ++c) {
        // ... minus the kernel's DC term, which RPN drops so that the mean is kept exactly.
        double energy = 0, sum = 0;
        for (std::size_t k = 0; k < t.plane_size(); ++k) {
            energy += double(t.plane(c)[k]) * t.plane(c)[k];
            sum += t.plane(c)[k];
        }
        energy -= sum * sum / double(t.plane_size());
        EXPECT_NEAR(mz.covariance(c, c), energy, 1e-4 * energy);
        EXPECT_NEAR(energy, m.covariance(c, c), 0.15 * m.covariance(c, c));
    }
    double wrap = 0, inner = 0;
    for (int y = 0; y < z.height; ++y) {
        wrap += std::abs(z.at(0, z.width - 1, y) - z.at(0, 0, y));
        for (int x = 0; x + 1 < z.width; ++x) inner += std::abs(z.at(0, x + 1, y) - z.at(0, x, y));
    }
    wrap /= z.height;
    inner /= double(z.height) * (z.width - 1);
    EXPECT_LT(wrap, 1.3 * inner);
}

TEST(SpectralSynthesis, FromATextonHasTheTextonMeanAndIsSeeded) {
    AnalysisParams p;
    p.size = 16;
    auto r = analyze_texton(sand64(), p);
    ASSERT_TRUE(r.ok());
    const Texton& t = r.value().texton;
    const Image a = synthesize_from_texton(t, SpectralMethod::rpn, 100, 70, 1);
    const Image b = synthesize_from_texton(t, SpectralMethod::rpn, 100, 70, 2);
    ASSERT_EQ(a.width, 100);
    EXPECT_NE(a.data, b.data);
    EXPECT_EQ(a.data, synthesize_from_texton(t, SpectralMethod::rpn, 100, 70, 1).data);
    // The output is a crop of the padded domain, so its mean is not exact (the domain's is:
    // RpnKeepsTheDomainMeanExactly). Over 64 seeds the crop means average to the texton mean
    // within 4 standard errors, measured from those 64.
    const int seeds = 64;
    double sum = 0, sum2 = 0;
    for (int s = 0; s < seeds; ++s) {
        const Image x = synthesize_from_texton(t, SpectralMethod::rpn, 100, 70,
                                               static_cast<std::uint64_t>(100 + s));
        const double m = test::moments(x.plane(1), x.plane_size()).mean;
        sum += m;
        sum2 += m * m;
    }
    const double avg = sum / seeds,
                 sd = std::sqrt((sum2 / seeds - avg * avg) * seeds / (seeds - 1));
    EXPECT_NEAR(avg, t.mean[1], 4 * sd / std::sqrt(double(seeds)));
}

// Random phases leave the zero frequency alone: on the synthesis domain the mean is exact, up to
// float rounding (about 1e-7 of the deviation a pixel, 1e-5 is far above its sum).
TEST(SpectralSynthesis, RpnKeepsTheDomainMeanExactly) {
    const int w = 48, h = 40;
    const Image k = test::white_noise(w, h, 3, 9);
    std::vector<Spectrum> k_hat;
    for (int c = 0; c < 3; ++c) {
        k_hat.emplace_back(w, h);
        RealFft2d::get(w, h)->forward(k.plane(c), k_hat.back(), 1);
    }
    const ChannelValues mean = {0.2, 0.5, 0.7};
    const Image out = spectral_synthesis(k_hat, mean, SpectralMethod::rpn, 3, 1);
    for (int c = 0; c < 3; ++c) {
        const test::Moments m = test::moments(out.plane(c), out.plane_size());
        EXPECT_GT(m.variance, 0.0);
        EXPECT_NEAR(m.mean, mean[static_cast<std::size_t>(c)], 1e-5 * std::sqrt(m.variance)) << c;
    }
    // ADSN keeps it only on average: one draw is off by about its standard error.
    const Image adsn = spectral_synthesis(k_hat, mean, SpectralMethod::adsn, 3, 1);
    EXPECT_GT(std::fabs(test::moments(adsn.plane(0), adsn.plane_size()).mean - mean[0]),
              1e-5 * std::sqrt(test::moments(adsn.plane(0), adsn.plane_size()).variance));
}
