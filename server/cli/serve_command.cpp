#include "server/app/build_id.h"
#include "server/cli/args.h"
#include "server/cli/commands.h"
#include "server/cli/stderr_capture.h"
#include "server/http/config.h"
#include "server/http/textond_server.h"
#include "server/store/redis_store.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <malloc.h>
#include <pthread.h>
#include <sstream>
#include <thread>

namespace textond::cli {

namespace {

const char* kHelp = R"(usage: textond serve [options]

Runs the HTTP service (API: /v1/openapi.yaml). Every option can also be set by an environment
variable: --cache-mb 512 is TEXTOND_CACHE_MB=512. Flags win over the environment.

  --host ADDR              address to listen on                                [127.0.0.1]
  --port N                 port, 0 = any free port (printed)                   [8080]
  --data DIR               texton store directory                              [./data]
  --store URL              shared texton store for replicas: redis://[[user]:pass@]host[:port][/db];
                           the data directory becomes its read-through cache   [none]
  --store-timeout-ms N     shared store connect and command timeout            [1000]
  --store-recheck-s N      seconds before a local copy is rechecked against the shared store
                           (a texton deleted on one replica is gone from all after this) [30]
  --meta-cache N           textons whose metadata stays in memory, most recently used (the
                           others are read from their files when asked for)   [10000]
  --backend B              auto | cpu | osmesa | egl (auto: GPU via EGL, else CPU) [auto]
  --public-url URL         base of the absolute URLs in TileJSON      [from the Host header]
  --api-key KEY            require "Authorization: Bearer KEY" for POST and DELETE  [none]
  --url-signing-key KEY    image URLs need sig (HMAC-SHA256, textond sign URL), else 403 [none]
  --presets FILE           image URLs name one of these JSON parameter sets (preset=NAME) [none]
  --cors-origin O          "*", a comma-separated list of origins, or "" for no CORS   [*]
  --web-dir DIR            the page served at / (built into build/release/web)

  --http-threads N         connection threads kept (one per open connection)   [128]
  --max-connections N      connections served at once; threads past --http-threads start
                           on demand, so slow clients cannot take them all     [1024]
  --listen-backlog N       pending connections before the kernel drops SYNs    [1024]
  --render-slots N         renders at once, 0 = one per core (plus a GPU batch
                           when all noise goes to a GL backend)                [0]
  --gpu-batch-tiles N      GL: windows rendered in one batch at most           [64]
  --gpu-batch-wait-us N    GL: how long a batch waits for more windows         [200]
  --gpu-batch-ms N         GL: measured work one batch holds at most (all its
                           windows are answered when it ends)                  [25]
  --gpu-lanes N            GL: batches in flight at once, each with a context
                           of its own; 0 = 3 on a GPU, 1 in software           [0]
  --analysis-workers N     analyses at once (each uses every core)             [1]
  --analysis-queue N       analyses waiting before uploads get 429             [4]
  --cache-mb N             in-memory image cache budget, MiB                   [256]
  --table-cache-mb N       prepared textons' level tables kept, MiB (rebuilt past it) [256]
  --png-compression N      zlib level of PNG images, 0..9 (1: 19-39% smaller, 8x slower) [0]

  --max-upload-mb N        largest request body, MiB (413 above)               [32]
  --max-pixels N           largest image decoded (exemplar, mix mask, splat weights), pixels,
                           read from the header (413)                          [16777216]
  --formats LIST           upload formats, of png,jpeg,tiff,bmp,openexr (415 otherwise)
                           [png,jpeg,tiff,bmp: EXR is opt-in, see tests/README.md "Fuzzing"]
  --max-region-pixels N    largest region image                                [8388608]
  --max-tileable-side N    largest tileable texture side                       [4096]
  --read-timeout S, --write-timeout S                                          [30]
  --keep-alive-max N       requests per connection                             [1000]
  --keep-alive-timeout S   idle seconds before a kept-alive connection closes  [5]
  --max-header-kb N        request line and headers, KiB (431 above)           [64]
  --max-headers N          header lines (431 above)                            [100]
  --header-timeout S       seconds for a whole request head from its first byte (408) [10]
  --body-timeout S         seconds for a whole request body (408)              [120]
  --queue-timeout-ms N     longest wait for a render slot before 429           [10000]
  --render-queue N         requests waiting for a render slot before 429       [1024]
  --render-rate N          renders (cache misses) one client may start a minute, 0 = any;
                           a client is the --api-key's holder, else an address (429) [0]
  --render-burst N         renders one client may start at once within its rate [20]
  --max-request-cpu-s S    estimated CPU seconds one request may cost (413 above) [20]
  --render-deadline-s S    admitted work is abandoned after S seconds (503)    [60]
  --body-budget-mb N       request bodies held in memory by all requests, MiB (429) [256]

  --log-level L            trace | debug | info | warn | error | off           [info]
  --no-access-log          no log line per request
)";

const std::vector<std::string> kValueOptions = {"--host",
                                                "--port",
                                                "--data",
                                                "--store",
                                                "--store-timeout-ms",
                                                "--store-recheck-s",
                                                "--meta-cache",
                                                "--backend",
                                                "--public-url",
                                                "--api-key",
                                                "--url-signing-key",
                                                "--presets",
                                                "--cors-origin",
                                                "--web-dir",
                                                "--listen-backlog",
                                                "--http-threads",
                                                "--render-slots",
                                                "--gpu-batch-tiles",
                                                "--gpu-batch-wait-us",
                                                "--gpu-batch-ms",
                                                "--gpu-lanes",
                                                "--analysis-workers",
                                                "--analysis-queue",
                                                "--cache-mb",
                                                "--table-cache-mb",
                                                "--png-compression",
                                                "--max-upload-mb",
                                                "--max-pixels",
                                                "--formats",
                                                "--max-region-pixels",
                                                "--max-tileable-side",
                                                "--read-timeout",
                                                "--write-timeout",
                                                "--keep-alive-max",
                                                "--keep-alive-timeout",
                                                "--max-connections",
                                                "--max-header-kb",
                                                "--max-headers",
                                                "--header-timeout",
                                                "--body-timeout",
                                                "--queue-timeout-ms",
                                                "--render-queue",
                                                "--render-rate",
                                                "--render-burst",
                                                "--max-request-cpu-s",
                                                "--render-deadline-s",
                                                "--body-budget-mb",
                                                "--log-level"};
const std::vector<std::string> kFlagOptions = {"--no-access-log"};

// --max-upload-mb <-> TEXTOND_MAX_UPLOAD_MB
std::string env_name(const std::string& flag) {
    std::string e = "TEXTOND_";
    for (char c : flag.substr(2)) e += c == '-' ? '_' : static_cast<char>(std::toupper(c));
    return e;
}

// Environment first, then the command line, so flags override.
Argv with_environment(const Argv& argv) {
    Argv merged;
    for (const auto& o : kValueOptions)
        if (const char* v = std::getenv(env_name(o).c_str())) merged.insert(merged.end(), {o, v});
    for (const auto& f : kFlagOptions)
        if (const char* v = std::getenv(env_name(f).c_str()); v && std::string(v) == "1")
            merged.push_back(f);
    merged.insert(merged.end(), argv.begin(), argv.end());
    return merged;
}

// The numeric flags, each in its range; sizes are given in MB or kB and kept in bytes.
std::optional<Error> read_numbers(const Args& a, http::ServeConfig& c) {
    auto num = [&](const char* name, long long fallback, long long lo, long long hi,
                   auto& out) -> std::optional<Error> {
        auto v = a.get_int(name, fallback, lo, hi);
        if (!v) return v.error();
        out = static_cast<std::remove_reference_t<decltype(out)>>(v.value());
        return std::nullopt;
    };
    long long cache_mb = 256, upload_mb = 32, max_pixels = 16'777'216, header_kb = 64,
              body_budget_mb = 256, cpu_s = 20;
    for (auto err :
         {num("--port", c.port, 0, 65535, c.port),
          num("--http-threads", c.http_threads, 1, 4096, c.http_threads),
          num("--store-timeout-ms", c.store_timeout_ms, 10, 60000, c.store_timeout_ms),
          num("--store-recheck-s", c.store_recheck_s, 0, 86400, c.store_recheck_s),
          num("--meta-cache", c.meta_cache, 1, 100'000'000, c.meta_cache),
          num("--render-slots", c.render_slots, 0, 1024, c.render_slots),
          num("--gpu-batch-tiles", c.gpu_batch_tiles, 1, 1024, c.gpu_batch_tiles),
          num("--gpu-batch-wait-us", c.gpu_batch_wait_us, 0, 100000, c.gpu_batch_wait_us),
          num("--gpu-batch-ms", c.gpu_batch_ms, 1, 60000, c.gpu_batch_ms),
          num("--gpu-lanes", c.gpu_lanes, 0, 16, c.gpu_lanes),
          num("--analysis-workers", c.analysis_workers, 1, 64, c.analysis_workers),
          num("--analysis-queue", c.analysis_queue, 0, 10000, c.analysis_queue),
          num("--cache-mb", cache_mb, 0, 1 << 20, cache_mb),
          num("--png-compression", c.png_compression, 0, 9, c.png_compression),
          num("--max-upload-mb", upload_mb, 1, 4096, upload_mb),
          num("--max-pixels", max_pixels, 1, 1LL << 32, max_pixels),
          num("--max-region-pixels", c.limits.max_region_pixels, 1, 1LL << 26,
              c.limits.max_region_pixels),
          num("--max-tileable-side", c.limits.max_tileable_side, 8, 16384,
              c.limits.max_tileable_side),
          num("--read-timeout", c.read_timeout_s, 1, 3600, c.read_timeout_s),
          num("--write-timeout", c.write_timeout_s, 1, 3600, c.write_timeout_s),
          num("--keep-alive-max", c.keep_alive_max, 1, 1000000, c.keep_alive_max),
          num("--keep-alive-timeout", c.keep_alive_timeout_s, 1, 3600, c.keep_alive_timeout_s),
          num("--max-connections", c.max_connections, 1, 65536, c.max_connections),
          num("--max-header-kb", header_kb, 1, 1024, header_kb),
          num("--max-headers", c.max_headers, 1, 10000, c.max_headers),
          num("--header-timeout", c.header_timeout_s, 1, 3600, c.header_timeout_s),
          num("--body-timeout", c.body_timeout_s, 1, 3600, c.body_timeout_s),
          num("--queue-timeout-ms", c.queue_timeout_ms, 0, 3'600'000, c.queue_timeout_ms),
          num("--render-queue", c.render_queue, 0, 1'000'000, c.render_queue),
          num("--render-rate", c.render_rate, 0, 1'000'000, c.render_rate),
          num("--render-burst", c.render_burst, 1, 1'000'000, c.render_burst),
          num("--max-request-cpu-s", cpu_s, 1, 86400, cpu_s),
          num("--render-deadline-s", c.render_deadline_s, 1, 86400, c.render_deadline_s),
          num("--body-budget-mb", body_budget_mb, 1, 1 << 20, body_budget_mb)})
        if (err) return err;
    c.cache_bytes = static_cast<std::size_t>(cache_mb) << 20;
    c.max_upload_bytes = static_cast<std::size_t>(upload_mb) << 20;
    c.max_pixels = static_cast<std::uint64_t>(max_pixels);
    c.max_header_bytes = static_cast<std::size_t>(header_kb) << 10;
    c.body_budget_bytes = static_cast<std::size_t>(body_budget_mb) << 20;
    c.max_request_cpu_s = static_cast<double>(cpu_s);
    if (c.body_budget_bytes < c.max_upload_bytes)
        return Error{ErrorCode::invalid_argument,
                     "--body-budget-mb must be at least --max-upload-mb"};
    if (c.max_connections < c.http_threads) c.max_connections = c.http_threads;
    return std::nullopt;
}

// What prepared textons derive, kept within this many MiB (render/table_budget.h).
std::optional<Error> read_table_cache(const Args& a, http::ServeConfig& c) {
    auto mb = a.get_int("--table-cache-mb", 256, 0, 1 << 20);
    if (!mb) return mb.error();
    c.table_cache_bytes = static_cast<std::size_t>(mb.value()) << 20;
    return std::nullopt;
}

// The upload formats: a subset of the decoders we allow.
std::optional<Error> read_formats(const Args& a, http::ServeConfig& c) {
    if (!a.options.count("--formats")) return std::nullopt;
    c.formats = http::split_list(a.get("--formats"));
    const std::vector<std::string> known = {"png", "jpeg", "tiff", "openexr", "bmp"};
    for (const auto& f : c.formats)
        if (std::find(known.begin(), known.end(), f) == known.end())
            return Error{ErrorCode::invalid_argument,
                         "--formats: unknown format '" + f + "' (png, jpeg, tiff, openexr, bmp)"};
    if (c.formats.empty())
        return Error{ErrorCode::invalid_argument, "--formats: name at least one format"};
    return std::nullopt;
}

Result<http::ServeConfig> config_from(const Args& a) {
    http::ServeConfig c;
    if (auto err = read_numbers(a, c)) return *err;
    if (auto err = read_table_cache(a, c)) return *err;
    c.host = a.get("--host", c.host);
    c.data_dir = a.get("--data", c.data_dir);
    c.store_url = a.get("--store", c.store_url);
    if (!c.store_url.empty())
        if (auto url = store::parse_redis_url(c.store_url); !url) return url.error();
    c.public_url = a.get("--public-url", c.public_url);
    c.api_key = a.get("--api-key", c.api_key);
    c.url_signing_key = a.get("--url-signing-key", c.url_signing_key);
    if (!c.url_signing_key.empty() && c.url_signing_key.size() < app::kMinSigningKey)
        return make_error(ErrorCode::invalid_argument, "--url-signing-key must have at least " +
                                                           std::to_string(app::kMinSigningKey) +
                                                           " characters");
    if (a.options.count("--presets")) {
        std::ifstream in(a.get("--presets"), std::ios::binary);
        if (!in)
            return make_error(ErrorCode::invalid_argument,
                              "--presets: cannot read " + a.get("--presets"));
        std::stringstream text;
        text << in.rdbuf();
        auto presets = app::parse_presets(text.str());
        if (!presets)
            return make_error(ErrorCode::invalid_argument,
                              "--presets " + a.get("--presets") + ": " + presets.error().message);
        c.presets = std::move(presets.value());
    }
    c.cors_origin = a.get("--cors-origin", c.cors_origin);
    c.log_level = a.get("--log-level", c.log_level);
    c.web_dir = a.get("--web-dir", c.web_dir);
    c.access_log = !a.flags.count("--no-access-log");
    auto kind = render::parse_backend_kind(a.get("--backend", "auto"));
    if (!kind) return kind.error();
    c.backend = kind.value();
    if (auto err = read_formats(a, c)) return *err;
    if (spdlog::level::from_str(c.log_level) == spdlog::level::off && c.log_level != "off")
        return make_error(ErrorCode::invalid_argument,
                          "--log-level must be trace, debug, info, warn, error or off");
    return c;
}

void tune_malloc() {
    // Cached tiles (about 200 kB each) live long and die out of order. glibc raises its mmap
    // threshold after the first such free and then carves them from per-thread arenas, which
    // fragment: a replica grew 96 MiB beyond a full 64 MiB cache in a 60-second soak. Fixed at
    // 128 kB, every tile buffer is its own mapping and goes back to the system when evicted
    // (2 MiB of growth in the same soak; tests/load/replicas_test.sh).
    ::mallopt(M_MMAP_THRESHOLD, 128 * 1024);
    // Fixing the mmap threshold also fixes the trim threshold at its 128 kB default: each
    // thread's arena then gave its top back (madvise, a TLB shootdown on every core) and faulted
    // it in again for the next tile's small buffers, a third of the server's CPU per cold tile
    // (4.0 -> 2.1 CPU-ms/tile under load_test.sh). 1 MiB kept per arena (glibc makes at
    // most 8 per core) ends that.
    ::mallopt(M_TRIM_THRESHOLD, 1024 * 1024);
}

// Signals are taken by one thread with sigwait, never by a handler in a random thread: they are
// blocked before any thread starts so every thread inherits the mask.
sigset_t block_stop_signals() {
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    sigaddset(&stop_signals, SIGHUP); // its terminal closed: drained too, not killed mid-request
    pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
    std::signal(SIGPIPE, SIG_IGN);
    return stop_signals;
}

} // namespace

int serve_command(const Argv& argv) {
    std::set<std::string> options(kValueOptions.begin(), kValueOptions.end());
    std::set<std::string> flags(kFlagOptions.begin(), kFlagOptions.end());
    flags.insert("--help");
    auto args = parse_args(with_environment(argv), options, flags);
    if (!args) return fail(2, args.error().message + " (see textond serve --help)");
    if (args.value().flags.count("--help")) {
        std::fputs(kHelp, stdout);
        return 0;
    }
    if (!args.value().positional.empty())
        return fail(2, "serve takes no positional arguments (see textond serve --help)");
    tune_malloc();
    auto config = config_from(args.value());
    if (!config) return fail(2, config.error().message);
    spdlog::set_level(spdlog::level::from_str(config.value().log_level));

    const sigset_t stop_signals = block_stop_signals();

    // From here on a library's own line on stderr is logged as a line of the log; a failure to
    // start is printed as it is, once stderr is back.
    auto capture = StderrCapture::start();
    auto service = http::TextondServer::create(config.value());
    if (!service) {
        capture.reset();
        return fail(1, service.error().message);
    }
    auto port = service.value()->bind();
    if (!port) {
        service.value().reset();
        capture.reset();
        return fail(1, port.error().message);
    }
    http::TextondServer& svc = *service.value();
    spdlog::info("backend: {}", svc.backend_description());
    spdlog::info("build: {}", app::build_id());
    // The URL on stdout (one line) so scripts and tests can read the port chosen by --port 0.
    std::printf("textond listening on http://%s:%d/\n", config.value().host.c_str(), port.value());
    std::fflush(stdout);

    std::thread signal_thread([&svc, stop_signals] {
        int sig = 0;
        sigwait(&stop_signals, &sig);
        spdlog::info("signal {}: stopping (finishing requests in flight)", sig);
        svc.stop();
    });
    svc.run();
    // run() returned: stop() was called by the signal thread (or the listener failed).
    if (signal_thread.joinable()) {
        // Wakes the signal thread's sigwait (SIGTERM is blocked in every thread, so nothing is
        // terminated): its one way out when the listener failed without a signal.
        // NOLINTNEXTLINE(bugprone-bad-signal-to-kill-thread)
        pthread_kill(signal_thread.native_handle(), SIGTERM);
        signal_thread.join();
    }
    service.value().reset();
    spdlog::info("stopped");
    capture.reset();
    return 0;
}

} // namespace textond::cli
