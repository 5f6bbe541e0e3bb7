// The micro/macro verdict (core/shape_verdict.h) on its six labelled corpora (tests/verdict/,
// and its shapes/, third/, fourth/, fifth/ and sixth/): the held-out halves of the shapes, third
// and fourth corpora and the fifth and sixth whole, the fit set as fitted, and random-phase
// textures. Labels and splits were fixed before any score.
#include "core/shape_verdict.h"
#include "core/spectral_synthesis.h"
#include "server/io/image_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

using namespace textond;

namespace {

// A labelled photo. Each test decodes and scores only the photos it counts: the verdict of the
// whole corpus in every test process took four times 45 s of CPU.
struct Labelled {
    std::string name, label, half, path;
    std::string corpus; // first | shapes | third | fourth
};

std::vector<Labelled> read_corpus(const std::string& dir, const std::string& corpus) {
    std::vector<Labelled> out;
    std::ifstream tsv(dir + "/corpus.tsv");
    std::string line;
    std::getline(tsv, line);
    while (std::getline(tsv, line)) {
        std::istringstream f(line);
        Labelled l;
        std::getline(f, l.name, '\t');
        std::getline(f, l.label, '\t');
        std::getline(f, l.half, '\t');
        l.path = dir + "/corpus/" + l.name + ".jpg";
        l.corpus = corpus;
        out.push_back(std::move(l));
    }
    return out;
}

const std::vector<Labelled>& corpus() {
    static const std::vector<Labelled> all = [] {
        auto out = read_corpus(TEXTOND_VERDICT_CORPUS, "first");
        for (const char* c : {"shapes", "third", "fourth", "fifth", "sixth"})
            for (auto& l : read_corpus(std::string(TEXTOND_VERDICT_CORPUS) + "/" + c, c))
                out.push_back(std::move(l));
        return out;
    }();
    return all;
}

core::Image image_of(const Labelled& l) {
    auto u = io::decode_image_file(l.path);
    EXPECT_TRUE(u) << l.name << ": " << (u ? "" : u.error().message);
    return u ? std::move(u.value()) : core::Image{};
}

struct Tally {
    int micro = 0, micro_right = 0, macro = 0, macro_right = 0, macro_called_micro = 0;
    std::string wrong; // "name (label -> kind)", for the README's table
};

// The labelled micro and macro photos `in` selects, each scored.
Tally tally(const std::function<bool(const Labelled&)>& in) {
    Tally t;
    for (const Labelled& l : corpus()) {
        if (!in(l) || l.label == "borderline") continue;
        const core::Image u = image_of(l);
        if (u.empty()) continue;
        const std::string kind = core::to_string(core::shape_verdict(u, 2).kind());
        if (kind != l.label) t.wrong += " " + l.name + " (" + l.label + " -> " + kind + ")";
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

// The fit set the verdict was chosen on: the whole first corpus and the shapes corpus's fit half
// (tests/verdict/fit_verdict.py).
bool in_fit_set(const Labelled& l) {
    return l.corpus == "first" || (l.corpus == "shapes" && l.half == "fit");
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
    std::map<std::string, std::map<std::string, int>> count;
    for (const Labelled& l : corpus()) ++count[l.corpus][l.label + " " + l.half];
    auto& first = count["first"];
    auto& shapes = count["shapes"];
    auto& third = count["third"];
    auto& fourth = count["fourth"];
    EXPECT_EQ(first["macro fit"] + first["macro held-out"], 40);
    EXPECT_EQ(first["micro fit"] + first["micro held-out"], 51);
    EXPECT_EQ(shapes["macro fit"], 51);
    EXPECT_EQ(shapes["macro held-out"], 50);
    EXPECT_EQ(shapes["micro fit"], 44);
    EXPECT_EQ(shapes["micro held-out"], 44);
    EXPECT_EQ(shapes["borderline fit"] + shapes["borderline held-out"], 32);
    EXPECT_EQ(third["macro fit"], 60);
    EXPECT_EQ(third["macro held-out"], 60);
    EXPECT_EQ(third["micro fit"], 24);
    EXPECT_EQ(third["micro held-out"], 23);
    EXPECT_EQ(third["borderline fit"] + third["borderline held-out"], 32);
    EXPECT_EQ(fourth["macro fit"], 26);
    EXPECT_EQ(fourth["macro held-out"], 25);
    EXPECT_EQ(fourth["micro fit"], 48);
    EXPECT_EQ(fourth["micro held-out"], 48);
    EXPECT_EQ(fourth["borderline fit"] + fourth["borderline held-out"], 24);
    // The fifth corpus, labelled and held out whole, before the second scale was chosen.
    auto& fifth = count["fifth"];
    EXPECT_EQ(fifth["macro held-out"], 12);
    EXPECT_EQ(fifth["micro held-out"], 71);
    EXPECT_EQ(fifth["borderline held-out"], 9);
    EXPECT_EQ(fifth.size(), 3u);
    // The sixth, labelled and held out whole after the second scale was chosen.
    auto& sixth = count["sixth"];
    EXPECT_EQ(sixth["macro held-out"], 41);
    EXPECT_EQ(sixth["micro held-out"], 11);
    EXPECT_EQ(sixth["borderline held-out"], 6);
    EXPECT_EQ(sixth.size(), 3u);
}

void report(const char* what, const Tally& t) {
    const int n = t.micro + t.macro, right = t.micro_right + t.macro_right;
    std::printf("%s: micro %d of %d right, macro %d of %d, %d macro called micro; "
                "P(>= %d of %d | p = 1/2) = %.2g\n  wrong:%s\n",
                what, t.micro_right, t.micro, t.macro_right, t.macro, t.macro_called_micro, right,
                n, binomial_tail(n, right, 0.5), t.wrong.c_str());
}

// A corpus's held-out half, scored and printed for the README's table, and far better than a
// coin (one-sided binomial test against p = 1/2 at the 0.001 level); each test then keeps what
// was reached as floors.
Tally held_out_half(const std::string& corpus) {
    const Tally t =
        tally([&](const Labelled& l) { return l.corpus == corpus && l.half == "held-out"; });
    report((corpus + " held-out").c_str(), t);
    EXPECT_LT(binomial_tail(t.micro + t.macro, t.micro_right + t.macro_right, 0.5), 1e-3);
    return t;
}

// A held-out corpus's floors: what it reached when scored once (no more of either kind wrong, no
// more macro called micro).
Tally expect_floors(const std::string& corpus, int micro_right, int macro_right,
                    int macro_called_micro) {
    const Tally t = held_out_half(corpus);
    EXPECT_GE(t.micro_right, micro_right);
    EXPECT_GE(t.macro_right, macro_right);
    EXPECT_LE(t.macro_called_micro, macro_called_micro);
    return t;
}

// The shapes corpus's held-out half, scored once after the choice (core/README.md "Micro or
// macro": 41 of 44 micro and 43 of 50 macro right, 4 macro called micro). The micro target (90%) is
// met, the macro one (90%: 45 of 50) and "no macro called micro" are missed, and these floors keep
// what was reached.
TEST(VerdictCorpus, HeldOutHalfOfTheShapesCorpus) {
    const Tally t = expect_floors("shapes", 0, 43, 4);
    EXPECT_GE(10 * t.micro_right, 9 * t.micro);
}

// The third corpus's held-out half, drawn and labelled after the verdict was chosen, so no
// choice has touched it: scored once (core/README.md "Micro or macro"; its fit half, not
// fitted on, gave 22 of 24 micro and 52 of 60 macro, 6 macro called micro).
TEST(VerdictCorpus, HeldOutHalfOfTheThirdCorpus) {
    // What was reached: 20 of 23 micro (the 90% target is missed by one texture), 58 of 60
    // macro (met), 2 macro called micro (the target of none is missed).
    expect_floors("third", 20, 58, 2);
}

// The fourth corpus's held-out half, drawn and labelled after the third's held-out half was
// scored, and scored once after the refit study on the first three corpora kept the verdict
// unchanged (core/README.md "Micro or macro"). Better than a coin, but its structured textures
// are where the verdict fails: dense small shapes (mosaic tiles, pebbles, crack networks,
// scattered leaves) read as micro. Floors of what was reached: 46 of 48 micro (the 90% target is
// met), 14 of 25 macro (the 90% target is missed by 9 textures), 9 macro called micro (the target
// is none). Its fit half gave 46 of 48 micro and 13 of 26 macro, 10 macro called micro.
TEST(VerdictCorpus, HeldOutHalfOfTheFourthCorpus) {
    expect_floors("fourth", 46, 14, 9);
}

// The fifth corpus, held out whole and scored once, after the second scale was chosen on the
// native sources of the first four (core/README.md "Two scales"). Its crops are 256 pixels, so
// they have one scale and the verdict on them is the one before; the README reports its native
// sources too (66 of 71 micro, 8 of 12 macro, 4 macro called micro). Floors of what the crops
// reached: 67 of 71 micro (the 90% target is met), 8 of 12 macro (missed: 11 would be 92%), 4
// macro called micro (missed).
TEST(VerdictCorpus, TheFifthCorpusHeldOutWhole) {
    expect_floors("fifth", 67, 8, 4);
}

// The sixth corpus, drawn rich in structured textures after the second scale was chosen, held
// out whole and scored once (core/README.md "Two scales"; its native sources: 10 of 11 micro, 37
// of 41 macro, 4 macro called micro). Floors of what its crops reached: 11 of 11 micro (met), 36
// of 41 macro (the 90% target is missed by one texture), 4 macro called micro (missed).
TEST(VerdictCorpus, TheSixthCorpusHeldOutWhole) {
    expect_floors("sixth", 11, 36, 4);
}

// The second scale on real textures: four of the fourth corpus's macro textures as the service
// sees them (their 512 x 512 sources, tests/verdict/fourth/native/, JPEG quality 95), whose
// shapes the reduction by 2 blurs away: at most borderline on the reduced whole (-2.2 to -0.2),
// macro at full resolution (+3.5 to +4.5 before the offset). The corpus tests above read crops
// of 256 pixels, which have one scale.
TEST(VerdictCorpus, TheSecondScaleSeesSmallShapesOfTheFourthCorpus) {
    for (const char* name : {"ad_bridge_wood_c", "ad_desert_city_tile_plaza",
                             "ad_polar_ice_cracked", "ad_savanna_tile_a"}) {
        auto u = io::decode_image_file(std::string(TEXTOND_VERDICT_CORPUS) + "/fourth/native/" +
                                       name + ".jpg");
        ASSERT_TRUE(u) << name;
        const core::ShapeVerdict v = core::shape_verdict(u.value(), 2);
        ASSERT_EQ(v.scales.size(), 2u) << name;
        EXPECT_LE(v.scales[0].score, core::kShapeBand) << name;
        EXPECT_EQ(v.factor, 1) << name;
        EXPECT_EQ(v.kind(), core::TextureKind::macro) << name;
    }
}

// The fit set is sorted as the fit found it (fit_verdict.py: 90 of 95 micro and 82 of 91 macro
// right): moving a weight or the band breaks this.
TEST(VerdictCorpus, FitSetIsSortedAsFitted) {
    const Tally t = tally(in_fit_set);
    EXPECT_GE(t.micro_right, 90) << "of " << t.micro;
    EXPECT_GE(t.macro_right, 82) << "of " << t.macro;
}

// A Gaussian texture has no shapes to lose: a random-phase synthesis of every macro texture of
// the six corpora is called micro, RPN and ADSN (with a seed the null does not use) in turn.
// One synthesis a texture, not both: the fourth corpus's 51 macro textures fit in the time both
// took for the first three's 261.
TEST(VerdictCorpus, EveryRandomPhaseVersionOfAMacroTextureIsMicro) {
    int n = 0;
    for (const Labelled& l : corpus()) {
        if (l.label != "macro") continue;
        const core::Image u = image_of(l);
        if (u.empty()) continue;
        const auto method = n % 2 ? core::SpectralMethod::adsn : core::SpectralMethod::rpn;
        const auto v =
            core::shape_verdict(core::synthesize_from_exemplar(u, method, 256, 256, 11), 2);
        EXPECT_EQ(v.kind(), core::TextureKind::micro) << l.name << " " << v.score;
        ++n;
    }
    EXPECT_EQ(n, 40 + 101 + 120 + 51 + 12 + 41);
}
