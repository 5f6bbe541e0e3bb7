#include "server/cli/texton_input.h"

#include "server/cli/analysis_options.h"
#include "server/io/image_io.h"
#include "server/io/texton_file.h"

#include <spdlog/spdlog.h>

namespace textond::cli {

Result<core::Texton> load_or_analyze(const std::string& input, const Args& a) {
    auto record = io::read_texton_file(input);
    if (record) return record.value().texton;
    auto params = analysis_params_from(a);
    if (!params) return params.error();
    auto limits = decode_limits_from(a);
    if (!limits) return limits.error();
    auto image = io::decode_image_file(input, limits.value());
    if (!image) return make_error(image.error().code, input + ": " + image.error().message);
    auto result =
        core::analyze_texton(image.value(), params.value(), progress_reporter("analyze " + input));
    if (!result) return result.error();
    spdlog::info("analysed {}: r = {}, RME {:.4f}", input, result.value().texton.size,
                 result.value().rme);
    return result.value().texton;
}

} // namespace textond::cli
