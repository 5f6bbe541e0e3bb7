// The micro/macro verdict's score at each scale it measures (core/shape_verdict.h), one row a
// texture: name, label, half, then factor:score from the coarsest scale to the finest (each the
// score of the image measured there, before kFineScaleOffset), and the kind the verdict gives.
// It reads corpus/NAME.png, or else corpus/NAME.jpg. The corpora's crops are 256 x 256, one
// scale; their native sources (tests/verdict/make_corpus.py native) have two from 512 pixels on
// the short side.
//   verdict_scales CORPUS_DIR...
#include "core/shape_verdict.h"
#include "tests/bench/corpus_table.h"

#include <cstdio>
#include <string>

using namespace textond;

int main(int argc, char** argv) {
    return bench::corpus_table(argc, argv, "\tscales\tkind", [](const core::Image& u) {
        const core::ShapeVerdict v = core::shape_verdict(u);
        std::string out = "\t";
        char buf[48];
        for (std::size_t k = 0; k < v.scales.size(); ++k) {
            std::snprintf(buf, sizeof buf, "%s%d:%.3f", k ? "," : "", v.scales[k].factor,
                          v.scales[k].score);
            out += buf;
        }
        return out + '\t' + core::to_string(v.kind());
    });
}
