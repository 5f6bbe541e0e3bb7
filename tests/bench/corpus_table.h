#pragma once
// The labelled corpora's textures measured one row each, for the verdict's study programs
// (verdict_candidates, verdict_scales): DIR/corpus.tsv names each texture (name, label, half),
// DIR/corpus/NAME.png or else NAME.jpg holds it. Rows are measured on every core and printed in
// the files' order as a TSV: corpus, name, label, half, then what `measure` gives (each column
// after a tab). A texture that does not decode, or that `measure` fails on, is named on stderr and
// the exit status is 1 (the study would be short); a DIR without corpus.tsv, 2.
#include "core/image.h"
#include "server/io/image_io.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace textond::bench {

inline int corpus_table(int argc, char** argv, const std::string& header,
                        const std::function<Result<std::string>(const core::Image&)>& measure) {
    struct Row {
        std::string dir, name, label, half, line;
    };
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
                auto m = measure(u.value());
                r.line = m ? r.dir + '\t' + r.name + '\t' + r.label + '\t' + r.half + m.value()
                           : "!" + m.error().message;
            }
        });
    for (auto& t : pool) t.join();
    std::printf("corpus\tname\tlabel\thalf%s\n", header.c_str());
    int failed = 0;
    for (const Row& r : rows) {
        if (r.line.empty() || r.line[0] == '!') {
            std::fprintf(stderr, "%s/corpus/%s: %s\n", r.dir.c_str(), r.name.c_str(),
                         r.line.empty() ? "not measured" : r.line.c_str() + 1);
            ++failed;
        } else {
            std::printf("%s\n", r.line.c_str());
        }
    }
    return failed ? 1 : 0;
}

} // namespace textond::bench
