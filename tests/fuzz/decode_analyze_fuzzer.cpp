// libFuzzer target over what every upload goes through: format sniffing and the allow-list,
// OpenImageIO's decoders (from memory), validation, and the analysis itself (small parameters, so
// the fuzzer spends its time on inputs, not on FFTs).
#include "core/texton_analysis.h"
#include "server/io/image_io.h"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace textond;
    io::DecodeLimits limits;
    limits.max_pixels = 1 << 20; // the service's check, at a budget that keeps runs fast
    limits.formats = {"png", "jpeg", "tiff", "openexr", "bmp"};
    auto image = io::decode_image_memory(
        std::string_view(reinterpret_cast<const char*>(data), size), limits);
    if (!image) return 0;
    core::AnalysisParams params;
    params.size = 8;
    params.iterations = 2;
    params.threads = 1;
    const core::Image& u = image.value();
    if (core::validate_analysis(params, u.width, u.height, u.channels)) return 0;
    auto result = core::analyze_texton(u, params);
    // A decoded, valid exemplar must always analyse: anything else is a bug.
    if (!result) __builtin_trap();
    return 0;
}
