// The micro/macro verdict's score at each scale it measures (core/shape_verdict.h), one row a
// texture: name, label, half, then factor:score from the coarsest scale to the finest (each the
// score of the image measured there, before kFineScaleOffset), and the kind the verdict gives.
// It reads corpus/NAME.png, or else corpus/NAME.jpg. The corpora's crops are 256 x 256, one
// scale; their native sources (tests/verdict/make_corpus.py native) have two past 512 pixels.
//   verdict_scales CORPUS_DIR...
#include "core/shape_verdict.h"
#include "server/io/image_io.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using namespace textond;

namespace {

struct Row {
    std::string dir, name, label, half, line;
};

} // namespace

int main(int argc, char** argv) {
    std::vector<Row> rows;
    for (int a = 1; a < argc; ++a) {
        std::ifstream tsv(std::string(argv[a]) + "/corpus.tsv");
        if (!tsv) {
            std::fprintf(stderr, "no %s/corpus.tsv\n", argv[a]);
            return 2;
        }
        std::string line;
        std::getline(tsv, line);
        while (std::getline(tsv, line)) {
            std::istringstream f(line);
            Row r{argv[a], {}, {}, {}, {}};
            std::getline(f, r.name, '\t');
            std::getline(f, r.label, '\t');
            std::getline(f, r.half, '\t');
            rows.push_back(r);
        }
    }
    std::atomic<std::size_t> next{0};
    std::vector<std::thread> pool;
    const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
    for (unsigned t = 0; t < threads; ++t)
        pool.emplace_back([&] {
            for (std::size_t i; (i = next++) < rows.size();) {
                Row& r = rows[i];
                const std::string stem = r.dir + "/corpus/" + r.name;
                auto u = io::decode_image_file(stem + ".png");
                if (!u) u = io::decode_image_file(stem + ".jpg");
                if (!u) {
                    r.line = "!" + u.error().message;
                    continue;
                }
                const core::ShapeVerdict v = core::shape_verdict(u.value());
                std::ostringstream o;
                o << r.dir << '\t' << r.name << '\t' << r.label << '\t' << r.half << '\t';
                char buf[48];
                for (std::size_t k = 0; k < v.scales.size(); ++k) {
                    std::snprintf(buf, sizeof buf, "%s%d:%.3f", k ? "," : "", v.scales[k].factor,
                                  v.scales[k].score);
                    o << buf;
                }
                o << '\t' << core::to_string(v.kind());
                r.line = o.str();
            }
        });
    for (auto& t : pool) t.join();
    std::printf("corpus\tname\tlabel\thalf\tscales\tkind\n");
    int failed = 0;
    for (const Row& r : rows) {
        if (r.line.empty() || r.line[0] == '!') {
            std::fprintf(stderr, "%s/corpus/%s.jpg: %s\n", r.dir.c_str(), r.name.c_str(),
                         r.line.empty() ? "not measured" : r.line.c_str() + 1);
            ++failed;
        } else {
            std::printf("%s\n", r.line.c_str());
        }
    }
    return failed ? 1 : 0;
}
