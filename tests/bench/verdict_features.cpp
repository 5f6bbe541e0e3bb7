// The micro/macro verdict's statistics on a labelled corpus (tests/verdict/ or
// tests/verdict/shapes/), one row a texture: its label and half, the four shape statistics of
// core/shape_verdict.h (the exemplar's, its ADSN null's mean and sd), the score and kind, the
// phase coherence kept for reference, and the RME of its texton (default analysis). Fitting
// reads the fit halves only (tests/verdict/fit_verdict.py).
//   verdict_features CORPUS_DIR...   (default: tests/verdict tests/verdict/shapes)
#include "core/shape_verdict.h"
#include "core/texton_analysis.h"
#include "server/io/image_io.h"

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace textond;

namespace {

void print_statistics(const core::ShapeStatistics& s) {
    std::printf("\t%.5f\t%.5f\t%.5f\t%.5f", s.tensor, s.tv, s.lines, s.specks);
}

bool rows_of(const std::string& dir) {
    std::ifstream tsv(dir + "/corpus.tsv");
    if (!tsv) {
        std::fprintf(stderr, "no %s/corpus.tsv\n", dir.c_str());
        return false;
    }
    std::string line;
    std::getline(tsv, line); // header
    while (std::getline(tsv, line)) {
        std::istringstream f(line);
        std::string name, label, half;
        std::getline(f, name, '\t');
        std::getline(f, label, '\t');
        std::getline(f, half, '\t');
        auto u = io::decode_image_file(dir + "/corpus/" + name + ".jpg");
        if (!u) {
            std::fprintf(stderr, "%s: %s\n", name.c_str(), u.error().message.c_str());
            return false;
        }
        core::AnalysisParams params;
        params.threads = 2;
        auto r = core::analyze_texton(u.value(), params);
        if (!r || !r.value().shape || !r.value().coherence) {
            std::fprintf(stderr, "%s: analysis failed\n", name.c_str());
            return false;
        }
        const core::ShapeVerdict& v = *r.value().shape;
        std::printf("%s\t%s\t%s\t%s", dir.c_str(), name.c_str(), label.c_str(), half.c_str());
        print_statistics(v.exemplar);
        print_statistics(v.null_mean);
        print_statistics(v.null_sd);
        std::printf("\t%.4f\t%s\t%.4f\t%.4f\n", v.score, core::to_string(v.kind()),
                    r.value().coherence->index, r.value().rme);
        std::fflush(stdout);
    }
    return true;
}

} // namespace

int main(int argc, char** argv) {
    std::vector<std::string> dirs(argv + 1, argv + argc);
    if (dirs.empty()) dirs = {"tests/verdict", "tests/verdict/shapes"};
    std::printf("corpus\tname\tlabel\thalf");
    for (const char* part : {"", "_null", "_sd"})
        for (const char* s : {"tensor", "tv", "lines", "specks"}) std::printf("\t%s%s", s, part);
    std::printf("\tscore\tkind\tcoherence\trme\n");
    for (const auto& d : dirs)
        if (!rows_of(d)) return 1;
    return 0;
}
