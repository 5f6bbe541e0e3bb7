#include "core/spectral_synthesis.h"
#include "core/spot_noise.h"
#include "server/cli/analysis_options.h"
#include "server/cli/commands.h"
#include "server/io/image_io.h"
#include "server/io/texton_file.h"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>
#include <optional>

namespace textond::cli {

namespace {
const char* kHelp = R"(usage: textond synth INPUT --method adsn|rpn|dsn [options] -o OUT.png|OUT.exr

Reference syntheses. INPUT is an exemplar image or a texton file written by `textond analyze`.
  --method M        adsn: asymptotic discrete spot noise (Gaussian), rpn: random phase noise
                    (TIP 2011; from an exemplar through the spot extension, so any size, and the
                    output wraps around), dsn: discrete spot noise of the texton (SOT paper,
                    Algorithm 1; an exemplar is analysed first with the analysis options)
  --width W         output width in pixels, 1..16384                            [512]
  --height H        output height in pixels, 1..16384                           [512]
  --seed N          synthesis seed                                              [0]
  --mni N           dsn: mean number of impacts per pixel, 1..200               [30]
  --x0 X, --y0 Y    dsn: window origin on the plane                             [0]
  --png16           write a 16-bit PNG instead of 8-bit
  -o, --output FILE .png (clamped to [0,1]) or .exr (float)
)";
constexpr long long kMaxSide = 16384;
constexpr long long kMaxOutputPixels = 64LL * 1024 * 1024;

struct Synthesis {
    std::string method; // adsn | rpn | dsn
    int width = 512, height = 512;
    std::uint64_t seed = 0;
    double mni = 30.0;
    std::int64_t x0 = 0, y0 = 0;
};

Result<Synthesis> synthesis_from(const Args& a) {
    Synthesis s;
    s.method = a.get("--method", "");
    if (s.method != "adsn" && s.method != "rpn" && s.method != "dsn")
        return make_error(ErrorCode::invalid_argument, "--method must be adsn, rpn or dsn");
    auto width = a.get_int("--width", 512, 1, kMaxSide);
    auto height = a.get_int("--height", 512, 1, kMaxSide);
    auto seed = a.get_u64("--seed", 0);
    auto mni = a.get_double("--mni", 30.0, 1.0, 200.0);
    auto x0 = a.get_int("--x0", 0, -(1LL << 62), 1LL << 62);
    auto y0 = a.get_int("--y0", 0, -(1LL << 62), 1LL << 62);
    for (const Error* e : {width ? nullptr : &width.error(), height ? nullptr : &height.error(),
                           seed ? nullptr : &seed.error(), mni ? nullptr : &mni.error(),
                           x0 ? nullptr : &x0.error(), y0 ? nullptr : &y0.error()})
        if (e) return *e;
    if (width.value() * height.value() > kMaxOutputPixels)
        return make_error(ErrorCode::invalid_argument,
                          "output over " + std::to_string(kMaxOutputPixels) + " pixels");
    s.width = static_cast<int>(width.value());
    s.height = static_cast<int>(height.value());
    s.seed = seed.value();
    s.mni = mni.value();
    s.x0 = x0.value();
    s.y0 = y0.value();
    return s;
}

// A texton file is an EXR with our metadata; anything else is an exemplar. dsn needs a texton:
// an exemplar is analysed first. Errors: io (exit 1) for an unreadable input, else 2.
Result<core::Image> synthesize(const Synthesis& s, const std::string& input,
                               const core::AnalysisParams& params, const io::DecodeLimits& limits) {
    std::optional<core::Texton> texton;
    std::optional<core::Image> exemplar;
    if (auto record = io::read_texton_file(input)) {
        texton = std::move(record.value().texton);
    } else {
        auto image = io::decode_image_file(input, limits);
        if (!image) return make_error(ErrorCode::io, input + ": " + image.error().message);
        exemplar = std::move(image.value());
    }
    if (s.method == "dsn") {
        if (!texton) {
            auto result =
                core::analyze_texton(*exemplar, params, progress_reporter("analyze " + input));
            if (!result) return make_error(ErrorCode::invalid_argument, result.error().message);
            spdlog::info("analysed {}: RME {:.4f}", input, result.value().rme);
            texton = result.value().texton;
        }
        return core::discrete_spot_noise(*texton, s.mni, s.seed, {s.x0, s.y0, s.width, s.height});
    }
    const auto m = s.method == "adsn" ? core::SpectralMethod::adsn : core::SpectralMethod::rpn;
    return texton
               ? core::synthesize_from_texton(*texton, m, s.width, s.height, s.seed, params.threads)
               : core::synthesize_from_exemplar(*exemplar, m, s.width, s.height, s.seed,
                                                params.threads);
}
} // namespace

int synth_command(const Argv& argv) {
    // --seed is shared with the analysis options: one seed drives both.
    auto parsed = parse_input_command(
        argv, "synth", kHelp, "INPUT", true,
        {"--output", "--method", "--width", "--height", "--mni", "--x0", "--y0"}, {"--png16"});
    if (auto* code = std::get_if<int>(&parsed)) return *code;
    const Args& a = std::get<Args>(parsed);
    auto synthesis = synthesis_from(a);
    if (!synthesis) return fail(2, synthesis.error().message);
    auto params = analysis_params_from(a);
    if (!params) return fail(2, params.error().message);
    auto limits = decode_limits_from(a);
    if (!limits) return fail(2, limits.error().message);
    auto encoding = output_encoding_from(a);
    if (!encoding) return fail(2, encoding.error().message);
    auto out = synthesize(synthesis.value(), a.positional[0], params.value(), limits.value());
    if (!out) return fail(out.error().code == ErrorCode::io ? 1 : 2, out.error().message);
    auto written = io::encode_image_file(out.value(), a.get("--output"), encoding.value());
    if (!written) return fail(1, written.error().message);
    return 0;
}

} // namespace textond::cli
