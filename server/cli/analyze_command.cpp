#include "server/app/texton_service.h"
#include "server/cli/analysis_options.h"
#include "server/cli/commands.h"
#include "server/io/image_io.h"
#include "server/io/texton_file.h"

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <utility>
#include <vector>

namespace textond::cli {

const std::set<std::string> kAnalysisOptions = {"--size", "--order",   "--iterations",
                                                "--seed", "--threads", "--max-pixels"};
const std::set<std::string> kAnalysisFlags = {"--no-periodic"};
const char* kAnalysisHelp = R"(analysis options:
  --size R          texton support R x R, 8..256, at most half the short side   [64]
  --order N         interpolation order: 0 (discrete SOT), 1 (bilinear), 3 (cubic)   [1]
  --iterations N    alternating projections, 1..1000                            [50]
  --seed N          analysis seed (random phase start)                          [0]
  --no-periodic     skip the periodic component (not recommended)
  --threads N       worker threads, 0 = all cores (never changes the result)    [0]
  --max-pixels N    refuse exemplars over N pixels                              [16777216]
)";

Result<core::AnalysisParams> analysis_params_from(const Args& a) {
    core::AnalysisParams p;
    auto size = a.get_int("--size", p.size, 8, 256);
    if (!size) return size.error();
    auto order = a.get_int("--order", p.order, 0, 3);
    if (!order) return order.error();
    auto iterations = a.get_int("--iterations", p.iterations, 1, 1000);
    if (!iterations) return iterations.error();
    auto seed = a.get_u64("--seed", p.seed);
    if (!seed) return seed.error();
    auto threads = a.get_int("--threads", 0, 0, 256);
    if (!threads) return threads.error();
    p.size = static_cast<int>(size.value());
    p.order = static_cast<int>(order.value());
    p.iterations = static_cast<int>(iterations.value());
    p.seed = seed.value();
    p.threads = static_cast<int>(threads.value());
    p.periodic = !a.flags.count("--no-periodic");
    return p;
}

std::variant<Args, int> parse_input_command(const Argv& argv, const std::string& name,
                                            const char* help, const char* input_name,
                                            bool needs_output,
                                            const std::set<std::string>& own_options,
                                            const std::set<std::string>& own_flags,
                                            bool many_inputs) {
    std::set<std::string> options = kAnalysisOptions;
    options.insert(own_options.begin(), own_options.end());
    std::set<std::string> flags = kAnalysisFlags;
    flags.insert(own_flags.begin(), own_flags.end());
    flags.insert("--help");
    auto args = parse_args(argv, options, flags);
    if (!args) return fail(2, args.error().message + " (see textond " + name + " --help)");
    if (args.value().flags.count("--help")) {
        std::printf("%s\n%s", help, kAnalysisHelp);
        return 0;
    }
    if (!many_inputs && args.value().positional.size() != 1)
        return fail(2, name + " needs exactly one " + input_name + " (see textond " + name +
                           " --help)");
    if (needs_output && !args.value().options.count("--output"))
        return fail(2, name + " needs -o OUT.png or OUT.exr");
    return std::move(args.value());
}

Result<io::DecodeLimits> decode_limits_from(const Args& a) {
    io::DecodeLimits limits;
    auto max_pixels =
        a.get_int("--max-pixels", static_cast<long long>(limits.max_pixels), 1, 1LL << 40);
    if (!max_pixels) return max_pixels.error();
    limits.max_pixels = static_cast<std::uint64_t>(max_pixels.value());
    return limits;
}

Result<io::Encoding> output_encoding_from(const Args& a) {
    auto encoding = io::encoding_for_path(a.get("--output"));
    if (!encoding || !a.flags.count("--png16")) return encoding;
    if (encoding.value() != io::Encoding::png8)
        return make_error(ErrorCode::invalid_argument, "--png16 needs a .png output");
    return io::Encoding::png16;
}

core::ProgressFn progress_reporter(const std::string& label, const std::string& unit) {
    using clock = std::chrono::steady_clock;
    auto state = std::make_shared<std::pair<clock::time_point, clock::time_point>>(clock::now(),
                                                                                   clock::now());
    return [state, label, unit](int done, int total) {
        const auto now = clock::now();
        if (now - state->first < std::chrono::seconds(1)) return;
        if (done < total && now - state->second < std::chrono::seconds(1)) return;
        state->second = now;
        spdlog::info("{}: {} {}/{}", label, unit, done, total);
    };
}

namespace {
const char* kHelp =
    R"(usage: textond analyze EXEMPLAR [options] [-o TEXTON.exr] [--export-v1 FILE.texton]
       textond analyze EXEMPLAR... [--from-list FILE] [--jobs N] [options] -o DIR/

Estimates the Gaussian model of EXEMPLAR (any format OpenImageIO reads), computes its texton by
alternating projections and prints a JSON summary (id, RME, mean, timings) on stdout.
  -o, --output FILE     write the texton file (OpenEXR + metadata, see api/TEXTON_FORMAT.md)
  --export-v1 FILE      also write the authors' .texton v1 text format (their OpenGL viewer)
Many exemplars in one process (several EXEMPLARs, --from-list, --jobs, or -o naming a directory
or ending in /): each texton
goes to DIR/NAME.exr (NAME from the exemplar's file name), and each exemplar gets one JSON line
on stdout as soon as it is done (with --jobs, not in the order given): its summary, or
{"exemplar": {"path"}, "error": {"code", "message"}}, both naming the exemplar's path. A bad file does not stop the others; the exit status is 1 if any failed.
  --from-list FILE      also the exemplars named in FILE, one path a line ("-": stdin; blank
                        lines and lines starting with # are skipped)
  --jobs N              exemplars analysed at once, 1..64; each gets --threads, or its share
                        of the cores                                           [1]
)";

// The batch form's outputs: DIR/NAME.exr, NAME-2.exr, ... where two exemplars share a name.
std::vector<std::string> batch_outputs(const std::vector<std::string>& inputs,
                                       const std::string& dir) {
    std::set<std::string> used;
    std::vector<std::string> out;
    for (const std::string& in : inputs) {
        const std::string stem = std::filesystem::path(in).stem().string();
        std::string name = stem + ".exr";
        for (int k = 2; used.count(name); ++k) name = stem + "-" + std::to_string(k) + ".exr";
        used.insert(name);
        out.push_back((std::filesystem::path(dir) / name).string());
    }
    return out;
}

Result<std::vector<std::string>> batch_inputs(const Args& a) {
    std::vector<std::string> inputs = a.positional;
    if (!a.options.count("--from-list")) return inputs;
    const std::string list = a.get("--from-list");
    std::ifstream file;
    if (list != "-") {
        std::error_code ec; // a directory opens, and reads as an empty list
        file.open(list);
        if (!file || std::filesystem::is_directory(list, ec))
            return make_error(ErrorCode::not_found, "--from-list: cannot read " + list);
    }
    std::istream& in = list == "-" ? std::cin : file;
    for (std::string line; std::getline(in, line);) {
        while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
        if (!line.empty() && line[0] != '#') inputs.push_back(line);
    }
    return inputs;
}

nlohmann::json error_line(const std::string& path, const std::string& code,
                          const std::string& message) {
    nlohmann::json j;
    j["exemplar"]["path"] = path;
    j["error"] = {{"code", code}, {"message", message}};
    return j;
}

// One exemplar of a batch: its JSON line (a summary or an error) and whether it succeeded.
std::pair<nlohmann::json, bool> analyse_one(const std::string& path, const std::string& output,
                                            const core::AnalysisParams& params,
                                            const io::DecodeLimits& limits) {
    auto failed = [&](const Error& e) {
        return std::make_pair(error_line(path, to_string(e.code), e.message), false);
    };
    auto image = io::decode_image_file(path, limits);
    if (!image) return failed(image.error());
    auto analysed = app::TextonService::analyse(image.value(), params, {});
    if (!analysed) return failed(analysed.error());
    if (auto w = io::write_texton_file(output, analysed.value()); !w) return failed(w.error());
    nlohmann::json summary = analysed.value().meta;
    summary["exemplar"]["path"] = path;
    summary["output"] = output;
    return {summary, true};
}

// An output that is one of the inputs would replace an exemplar by its texton.
std::optional<std::string> overwrites_an_input(const std::vector<std::string>& inputs,
                                               const std::vector<std::string>& outputs) {
    for (const std::string& out : outputs)
        for (const std::string& in : inputs) {
            std::error_code ec;
            if (!std::filesystem::equivalent(out, in, ec)) continue;
            std::string why = out;
            why += " is the exemplar ";
            why += in;
            why += ": choose another -o DIR/";
            return why;
        }
    return std::nullopt;
}

// Analyses paths[i] into outputs[i] on `jobs` threads and prints each file's line as soon as it
// is done (the line names its exemplar), so that a batch stopped by Ctrl-C has printed a line for
// every file it finished; 1 if any failed.
int run_batch(const std::vector<std::string>& paths, const std::vector<std::string>& outputs,
              const core::AnalysisParams& params, const io::DecodeLimits& limits, int jobs) {
    std::atomic<std::size_t> next{0};
    std::atomic<bool> failed{false};
    std::mutex print;
    auto work = [&] {
        for (std::size_t i; (i = next++) < paths.size();) {
            std::pair<nlohmann::json, bool> done;
            try {
                done = analyse_one(paths[i], outputs[i], params, limits);
            } catch (const std::exception& e) { // out of memory, say: this file fails
                done = {error_line(paths[i], "internal", e.what()), false};
            } catch (...) {
                done = {error_line(paths[i], "internal", "unknown error"), false};
            }
            if (!done.second) failed = true;
            // A path need not be UTF-8: replaced, not thrown.
            const std::string line =
                done.first.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
            std::lock_guard lock(print);
            std::printf("%s\n", line.c_str());
            std::fflush(stdout);
        }
    };
    std::vector<std::thread> workers;
    for (int w = 0; w < std::min<int>(jobs, static_cast<int>(paths.size())); ++w)
        workers.emplace_back(work);
    for (auto& t : workers) t.join();
    return failed ? 1 : 0;
}

int analyze_many(const Args& a, core::AnalysisParams params, const io::DecodeLimits& limits) {
    if (a.options.count("--export-v1"))
        return fail(2, "--export-v1 takes one exemplar (see textond analyze --help)");
    auto inputs = batch_inputs(a);
    if (!inputs) return fail(2, inputs.error().message);
    if (inputs.value().empty())
        return fail(2, "analyze needs an EXEMPLAR (or --from-list FILE; see textond analyze "
                       "--help)");
    const std::string dir = a.options.count("--output") ? a.get("--output") : "";
    std::error_code ec;
    if (dir.empty() || (dir.back() != '/' && !std::filesystem::is_directory(dir, ec)))
        return fail(2, "analyze of many exemplars needs -o DIR/ (a directory, or a name ending "
                       "in /)");
    auto jobs = a.get_int("--jobs", 1, 1, 64);
    if (!jobs) return fail(2, jobs.error().message);
    std::string bare = dir; // "file/" does not stat as the file it names
    while (bare.size() > 1 && bare.back() == '/') bare.pop_back();
    if (std::filesystem::exists(bare, ec) && !std::filesystem::is_directory(bare, ec))
        return fail(2, dir + ": not a directory (-o DIR/ of many exemplars)");
    std::filesystem::create_directories(dir, ec);
    if (!std::filesystem::is_directory(dir, ec))
        return fail(1, dir + ": not a directory" + (ec ? " (" + ec.message() + ")" : ""));
    const auto n = static_cast<int>(jobs.value());
    if (params.threads == 0) // the cores shared out: the result never depends on them
        params.threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / n);
    const std::vector<std::string> outputs = batch_outputs(inputs.value(), dir);
    if (auto clash = overwrites_an_input(inputs.value(), outputs)) return fail(2, *clash);
    return run_batch(inputs.value(), outputs, params, limits, n);
}
} // namespace

int analyze_command(const Argv& argv) {
    auto parsed =
        parse_input_command(argv, "analyze", kHelp, "EXEMPLAR", false,
                            {"--output", "--export-v1", "--jobs", "--from-list"}, {}, true);
    if (auto* code = std::get_if<int>(&parsed)) return *code;
    const Args& a = std::get<Args>(parsed);
    auto params = analysis_params_from(a);
    if (!params) return fail(2, params.error().message);
    auto limits = decode_limits_from(a);
    if (!limits) return fail(2, limits.error().message);
    const std::string out = a.options.count("--output") ? a.get("--output") : "";
    std::error_code ec; // a directory we cannot stat is not one: the one-file form reports it
    if (a.positional.size() != 1 || a.options.count("--from-list") || a.options.count("--jobs") ||
        (!out.empty() && (out.back() == '/' || std::filesystem::is_directory(out, ec))))
        return analyze_many(a, params.value(), limits.value());

    const std::string& path = a.positional[0];
    auto image = io::decode_image_file(path, limits.value());
    if (!image) return fail(1, path + ": " + image.error().message);
    // The upload's own step (POST /v1/textons runs it on the analysis pool): one exemplar and one
    // set of parameters give one texton file, byte for byte, whichever way it was made.
    auto analysed = app::TextonService::analyse(image.value(), params.value(),
                                                progress_reporter("analyze " + path));
    if (!analysed)
        return fail(analysed.error().code == ErrorCode::invalid_argument ? 2 : 1,
                    analysed.error().message);
    const io::TextonRecord& record = analysed.value();
    if (a.options.count("--output")) {
        auto w = io::write_texton_file(a.get("--output"), record);
        if (!w) return fail(1, w.error().message);
    }
    if (a.options.count("--export-v1")) {
        const std::string name = std::filesystem::path(path).filename().string();
        auto w = io::write_file_atomic(a.get("--export-v1"), io::texton_v1_text(record, name));
        if (!w) return fail(1, w.error().message);
    }
    nlohmann::json summary = record.meta;
    summary["exemplar"]["path"] = path;
    if (a.options.count("--output")) summary["output"] = a.get("--output");
    std::printf("%s\n", summary.dump(2).c_str());
    return 0;
}

} // namespace textond::cli
