// The micro/macro verdict's candidate features on the labelled corpus (tests/verdict/), one row a
// texture with its label and half: the phase coherence of the current verdict (its index and each
// scale) and the band-pass kurtosis against random phase (core/band_kurtosis.h). Fitting reads
// the fit half only (tests/verdict/fit_verdict.py).
//   verdict_features [CORPUS_DIR]   (default: tests/verdict)
#include "core/band_kurtosis.h"
#include "core/periodic_component.h"
#include "core/phase_coherence.h"
#include "server/io/image_io.h"

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

using namespace textond;

int main(int argc, char** argv) {
    const std::string dir = argc > 1 ? argv[1] : "tests/verdict";
    std::ifstream tsv(dir + "/corpus.tsv");
    if (!tsv) {
        std::fprintf(stderr, "no %s/corpus.tsv\n", dir.c_str());
        return 1;
    }
    std::string line;
    std::getline(tsv, line); // header
    std::printf("name\tlabel\thalf\tcoherence\tc1\tc2\tc4\tc8\tlr1\tlr2\tlr4\tlr8\tkurt1\tkurt2\tku"
                "rt4\tkurt8\n");
    while (std::getline(tsv, line)) {
        std::istringstream f(line);
        std::string name, label, half;
        std::getline(f, name, '\t');
        std::getline(f, label, '\t');
        std::getline(f, half, '\t');
        auto u = io::decode_image_file(dir + "/corpus/" + name + ".jpg");
        if (!u) {
            std::fprintf(stderr, "%s: %s\n", name.c_str(), u.error().message.c_str());
            return 1;
        }
        const core::PhaseCoherence pc = core::phase_coherence(u.value(), 2);
        const auto bands = core::band_kurtosis(core::periodic_component(u.value(), 2), 4, 0, 2);
        std::printf("%s\t%s\t%s\t%.4f", name.c_str(), label.c_str(), half.c_str(), pc.index);
        for (std::size_t s = 0; s < 4; ++s)
            std::printf("\t%.4f", s < pc.scales.size() ? pc.scales[s].coherence : 0.0);
        for (std::size_t s = 0; s < 4; ++s)
            std::printf("\t%.4f", s < bands.size() ? bands[s].log_ratio : 0.0);
        for (std::size_t s = 0; s < 4; ++s)
            std::printf("\t%.3f", s < bands.size() ? bands[s].kurtosis : 0.0);
        std::printf("\n");
    }
    return 0;
}
