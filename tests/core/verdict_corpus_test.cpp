// The micro/macro verdict on its labelled corpus (tests/verdict/): held out, fitted,
// and on random-phase textures. Labels and the split were fixed before any score.
#include "core/phase_coherence.h"
#include "core/spectral_synthesis.h"
#include "server/io/image_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace textond;

namespace {

struct Labelled {
    std::string name, label, half;
    core::Image image;
};

const std::vector<Labelled>& corpus() {
    static const std::vector<Labelled> all = [] {
        std::vector<Labelled> out;
        const std::string dir = TEXTOND_VERDICT_CORPUS;
        std::ifstream tsv(dir + "/corpus.tsv");
        std::string line;
        std::getline(tsv, line);
        while (std::getline(tsv, line)) {
            std::istringstream f(line);
            Labelled l;
            std::getline(f, l.name, '\t');
            std::getline(f, l.label, '\t');
            std::getline(f, l.half, '\t');
            auto u = io::decode_image_file(dir + "/corpus/" + l.name + ".jpg");
            if (u) l.image = std::move(u.value());
            out.push_back(std::move(l));
        }
        return out;
    }();
    return all;
}

struct Tally {
    int micro = 0, micro_right = 0, macro = 0, macro_right = 0, macro_called_micro = 0;
};

Tally tally(const std::string& half) {
    Tally t;
    for (const Labelled& l : corpus()) {
        if (l.half != half || l.label == "borderline") continue;
        EXPECT_FALSE(l.image.empty()) << l.name;
        const std::string kind = core::to_string(core::phase_coherence(l.image, 2).kind());
        if (l.label == "micro") {
            ++t.micro;
            t.micro_right += kind == "micro";
        } else {
            ++t.macro;
            t.macro_right += kind == "macro";
            t.macro_called_micro += kind == "micro";
        }
    }
    return t;
}

// P(X >= k) for X ~ Binomial(n, p).
double binomial_tail(int n, int k, double p) {
    double sum = 0;
    for (int i = k; i <= n; ++i)
        sum += std::exp(std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0) +
                        i * std::log(p) + (n - i) * std::log(1 - p));
    return sum;
}

} // namespace

TEST(VerdictCorpus, HasTheDocumentedLabelsAndSplit) {
    int macro = 0, micro = 0, borderline = 0;
    for (const Labelled& l : corpus()) {
        macro += l.label == "macro";
        micro += l.label == "micro";
        borderline += l.label == "borderline";
    }
    EXPECT_GE(macro + micro + borderline, 60);
    EXPECT_GE(3 * macro, macro + micro + borderline); // at least a third macro
}

// The held-out half: the verdict is right (its label, out of three verdicts) far more often than
// a coin would be: one-sided binomial test against p = 1/2 at the 0.001 level (measured: 21 of
// 25 micro and 14 of 20 macro right, p = 5e-5; core/README.md "Micro or macro"). The 90% target is
// not reached, and one held-out macro (a dark, low-contrast stone wall) is called micro.
TEST(VerdictCorpus, HeldOutHalfIsRightFarMoreOftenThanChance) {
    const Tally t = tally("held-out");
    const int n = t.micro + t.macro, right = t.micro_right + t.macro_right;
    const double p = binomial_tail(n, right, 0.5);
    std::printf("held-out: micro %d of %d right, macro %d of %d, %d macro called micro; "
                "P(>= %d of %d | p = 1/2) = %.2g\n",
                t.micro_right, t.micro, t.macro_right, t.macro, t.macro_called_micro, right, n, p);
    EXPECT_LT(p, 1e-3);
    EXPECT_LE(t.macro_called_micro, 1);
}

// The fit half is sorted as the fit found it (fit_verdict.py: 20 of 26 micro, 19 of 20 macro,
// none called micro): moving the thresholds (a factor 1.5 on either) breaks this.
TEST(VerdictCorpus, FitHalfIsSortedAsFitted) {
    const Tally t = tally("fit");
    EXPECT_GE(t.micro_right, 20) << "of " << t.micro;
    EXPECT_GE(t.macro_right, 19) << "of " << t.macro;
    EXPECT_EQ(t.macro_called_micro, 0);
}

// A Gaussian texture has no phase coherence: the random-phase synthesis (ADSN) of every macro
// texture of the corpus, two seeds each, is called micro.
TEST(VerdictCorpus, EveryRandomPhaseVersionOfAMacroTextureIsMicro) {
    int n = 0;
    for (const Labelled& l : corpus()) {
        if (l.label != "macro" || l.image.empty()) continue;
        for (std::uint64_t seed : {1, 2}) {
            const auto p = core::phase_coherence(
                core::synthesize_from_exemplar(l.image, core::SpectralMethod::adsn, 256, 256, seed),
                2);
            EXPECT_EQ(p.kind(), core::TextureKind::micro) << l.name << " " << p.index;
            ++n;
        }
    }
    EXPECT_GE(n, 40);
}
