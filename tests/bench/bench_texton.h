#pragma once
// The texton the tile benchmarks render: a shared photo from the exemplar directory they are
// given, analysed at r = 64 (order 1) and prepared for the backends.
#include "core/texton_analysis.h"
#include "render/prepared_texton.h"
#include "server/io/image_io.h"

#include <memory>
#include <string>

namespace textond::test {

inline Result<std::shared_ptr<const render::PreparedTexton>> bench_texton(const std::string& path,
                                                                          int iterations) {
    auto exemplar = io::decode_image_file(path);
    if (!exemplar) return exemplar.error();
    core::AnalysisParams p;
    p.size = 64;
    p.iterations = iterations;
    auto analysed = core::analyze_texton(exemplar.value(), p);
    if (!analysed) return analysed.error();
    return render::PreparedTexton::make(analysed.value().texton);
}

} // namespace textond::test
