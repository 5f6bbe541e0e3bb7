#include "core/texture_mix.h"
#include "render/cpu_backend.h"
#include "server/cli/analysis_options.h"
#include "server/cli/commands.h"
#include "server/cli/window_options.h"
#include "server/io/image_io.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <sstream>

namespace textond::cli {

namespace {
const char* kHelp = R"(usage: textond mix U V [options] -o OUT.png|OUT.exr

Mixes two exemplars across space (texton-noise paper, section 7): the optimal-transport
barycentres of their Gaussian models at --levels values of rho, one texton each (same analysis
options and white-noise start for all), and a window of the noise whose Poisson points each take
the texton of the field rho(x) at their position. The default field is a horizontal ramp across
the window, from U on the left to V on the right. Prints a JSON summary on stdout.
  --levels R        barycentre levels, 2..64                                    [21]
  --ramp X0,Y0,DX,DY,WIDTH   ramp field in texels: rho = <x - origin, d> / WIDTH, clamped
  --mask FILE       field from a greyscale image instead (black = U, white = V)
  --mask-origin X,Y where the mask's top-left corner lies, texels                [0,0]
  --mask-scale S    texels per mask pixel                                       [1]
  --x X, --y Y      window origin in output pixels of the level                 [0]
  --w W, --h H      window size in pixels, 1..16384                             [1024, 256]
  --lod K           level -4..24: 2^K texels per output pixel                   [0]
  --mni M           mean number of impacts per pixel, 1..200                    [30]
  --png16           16-bit PNG instead of 8-bit
  -o, --output FILE .png (clamped to [0, 1]) or .exr (float32)
)";

Result<std::vector<double>> numbers(const std::string& text, std::size_t n, const char* what) {
    std::vector<double> v;
    std::stringstream s(text);
    for (std::string part; std::getline(s, part, ',');) {
        try {
            std::size_t used = 0;
            v.push_back(std::stod(part, &used));
            if (used != part.size()) throw std::invalid_argument(part);
        } catch (const std::exception&) {
            return make_error(ErrorCode::invalid_argument,
                              std::string(what) + ": not a number: " + part);
        }
    }
    if (v.size() != n)
        return make_error(ErrorCode::invalid_argument,
                          std::string(what) + " takes " + std::to_string(n) + " numbers");
    return v;
}

// The mixing field: a horizontal ramp across the window in texels unless --ramp or --mask.
// Errors carry the exit code they deserve: invalid_argument (2) or io (1).
Result<core::MixField> field_from(const Args& a, const render::NoiseRequest& q,
                                  const io::DecodeLimits& limits) {
    core::MixField field;
    const double texels = std::ldexp(1.0, q.level);
    field.x0 = static_cast<double>(q.x0) * texels;
    field.width = std::max(1.0, q.width * texels);
    if (a.has("--ramp") && a.has("--mask"))
        return make_error(ErrorCode::invalid_argument, "--ramp and --mask exclude each other");
    auto scale = a.get_double("--mask-scale", 1.0, 1.0 / 16, 1e9);
    if (!scale) return scale.error();
    if (a.has("--ramp")) {
        auto r = numbers(a.get("--ramp"), 5, "--ramp");
        if (!r) return r.error();
        field.x0 = r.value()[0];
        field.y0 = r.value()[1];
        field.dx = r.value()[2];
        field.dy = r.value()[3];
        field.width = r.value()[4];
    } else if (a.has("--mask")) {
        auto img = io::decode_image_file(a.get("--mask"), limits);
        if (!img) return make_error(ErrorCode::io, img.error().message);
        field.kind = core::MixField::Kind::mask;
        field.mask = core::mask_from_image(img.value());
        auto o = numbers(a.get("--mask-origin", "0,0"), 2, "--mask-origin");
        if (!o) return o.error();
        field.x0 = o.value()[0];
        field.y0 = o.value()[1];
        field.scale = scale.value();
    }
    if (auto err = field.validate()) return *err;
    return field;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

} // namespace

int mix_command(const Argv& argv) {
    std::set<std::string> options = kAnalysisOptions;
    options.insert({"--output", "--levels", "--ramp", "--mask", "--mask-origin", "--mask-scale",
                    "--x", "--y", "--w", "--h", "--lod", "--mni"});
    std::set<std::string> flags = kAnalysisFlags;
    flags.insert({"--png16", "--help"});
    auto parsed = parse_args(argv, options, flags);
    if (!parsed) return fail(2, parsed.error().message);
    const Args& a = parsed.value();
    if (a.flags.count("--help")) {
        std::printf("%s\n%s", kHelp, kAnalysisHelp);
        return 0;
    }
    if (a.positional.size() != 2) return fail(2, "mix takes two exemplars, U and V (see --help)");
    if (!a.has("--output")) return fail(2, "-o OUT.png|OUT.exr is required");
    auto params = analysis_params_from(a);
    if (!params) return fail(2, params.error().message);
    auto limits = decode_limits_from(a);
    if (!limits) return fail(2, limits.error().message);
    auto encoding = output_encoding_from(a);
    if (!encoding) return fail(2, encoding.error().message);
    auto levels = a.get_int("--levels", core::kDefaultMixLevels, 2, core::kMaxMixLevels);
    if (!levels) return fail(2, levels.error().message);
    auto q = window_from(a, 1024, 256);
    if (!q) return fail(2, q.error().message);
    q.value().seed = params.value().seed;
    auto field = field_from(a, q.value(), limits.value());
    if (!field) return fail(field.error().code == ErrorCode::io ? 1 : 2, field.error().message);

    auto u = io::decode_image_file(a.positional[0], limits.value());
    if (!u) return fail(1, u.error().message);
    auto v = io::decode_image_file(a.positional[1], limits.value());
    if (!v) return fail(1, v.error().message);
    const auto t0 = std::chrono::steady_clock::now();
    auto pair = core::common_models(u.value(), v.value(), params.value().periodic,
                                    params.value().threads, 2 * params.value().size);
    if (!pair) return fail(1, pair.error().message);
    auto mixed = core::mix_levels(pair.value(), params.value(), static_cast<int>(levels.value()),
                                  progress_reporter("mix", "level"));
    if (!mixed) return fail(1, mixed.error().message);
    const double analysis_ms = ms_since(t0);
    auto prepared = render::PreparedMix::make(mixed.value().levels, field.value());
    if (!prepared) return fail(1, prepared.error().message);
    if (auto err = prepared.value()->check(q.value())) return fail(2, err->message);
    render::CpuBackend cpu(params.value().threads);
    const auto t1 = std::chrono::steady_clock::now();
    auto image = cpu.render_mix(*prepared.value(), q.value());
    const double render_ms = ms_since(t1);
    if (!image) return fail(1, image.error().message);
    auto written = io::encode_image_file(image.value(), a.get("--output"), encoding.value(),
                                         {{"textond:noise", render::kNoiseVersion}});
    if (!written) return fail(1, written.error().message);
    nlohmann::json j = {
        {"levels", levels.value()},   {"grid", {pair.value().u.width, pair.value().u.height}},
        {"rme", mixed.value().rme},   {"analysis_ms", analysis_ms},
        {"render_ms", render_ms},     {"width", q.value().width},
        {"height", q.value().height}, {"output", a.get("--output")}};
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
}

} // namespace textond::cli
