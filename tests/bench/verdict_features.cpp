// The micro/macro verdict's statistics on labelled corpora (tests/verdict/ and the folders
// beside it), one row a texture: its label and half, the four shape statistics of
// core/shape_verdict.h (the exemplar's, its ADSN null's mean and sd), the score and kind, the
// phase coherence kept for reference, and the RME of its texton (default analysis). Fitting
// reads the fit halves only (tests/verdict/fit_verdict.py). It reads corpus/NAME.png, or else
// corpus/NAME.jpg, and measures the textures on every core (tests/bench/corpus_table.h).
//   verdict_features CORPUS_DIR...
#include "core/shape_verdict.h"
#include "core/texton_analysis.h"
#include "tests/bench/corpus_table.h"

#include <cstdio>
#include <string>

using namespace textond;

namespace {

std::string statistics(const core::ShapeStatistics& s) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "\t%.5f\t%.5f\t%.5f\t%.5f", s.tensor, s.tv, s.lines, s.specks);
    return buf;
}

} // namespace

int main(int argc, char** argv) {
    std::string header;
    for (const char* part : {"", "_null", "_sd"})
        for (const char* s : {"tensor", "tv", "lines", "specks"})
            header += std::string("\t") + s + part;
    header += "\tscore\tkind\tcoherence\trme";
    return bench::corpus_table(argc, argv, header, [](const core::Image& u) -> Result<std::string> {
        core::AnalysisParams params;
        params.threads = 1; // the rows are measured on every core already
        auto r = core::analyze_texton(u, params);
        if (!r) return r.error();
        if (!r.value().shape || !r.value().coherence)
            return make_error(ErrorCode::internal, "the analysis gave no verdict");
        const core::ShapeVerdict& v = *r.value().shape;
        char tail[96];
        std::snprintf(tail, sizeof tail, "\t%.4f\t%s\t%.4f\t%.4f", v.score,
                      core::to_string(v.kind()), r.value().coherence->index, r.value().rme);
        return statistics(v.exemplar) + statistics(v.null_mean) + statistics(v.null_sd) + tail;
    });
}
