// `textond export`: a texton's tiles over a box and a range of zooms, into one MBTiles or
// PMTiles archive for offline builds and static hosting. Tiles render in parallel and land in
// OUT.partial (an MBTiles database, committed every second), so an interrupted export resumes
// where it stopped; OUT appears only when every tile is in it.
#include "api/noise_fields.h"
#include "render/renderer.h"
#include "server/app/image_service.h"
#include "server/app/texton_source.h"
#include "server/cli/args.h"
#include "server/cli/commands.h"
#include "server/cli/export_plan.h"
#include "server/cli/progress_bar.h"
#include "server/io/crash_point.h"
#include "server/io/mbtiles.h"
#include "server/io/pmtiles.h"
#include "server/io/texton_file.h"

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <mutex>
#include <optional>
#include <set>
#include <system_error>
#include <thread>
#include <unordered_set>
#include <vector>

namespace textond::cli {

namespace {

const char* kHelp =
    R"(usage: textond export TEXTON --zooms A-B --bbox X0,Y0,X1,Y1 -o OUT.mbtiles|OUT.pmtiles

Writes the web-map tiles of TEXTON (a texton file: `textond analyze -o`, or a service's
/v1/textons/{id}/texton.exr) over a box of the plane into one archive: MBTiles 1.3 (SQLite) or
PMTiles v3 (one file a browser reads by range requests). Each tile has the bytes of the
service's /v1/textons/{id}/map/{z}/{x}/{y} with the same options and --png-compression (both
store PNGs, level 0, by default). Tiles render in parallel into
OUT.partial; run the same command again after an interruption and it resumes from there.

  --zooms A-B         map zooms, 0..24 (level = 24 - zoom; 24: one texel per pixel)
  --bbox X0,Y0,X1,Y1  the box in texels, 0 <= X0 < X1 <= tile size x 2^24 (same for Y)
  --format F          mbtiles | pmtiles                       [from OUT's extension]
  --tile-format T     png | png16 | webp | avif               [png]
  --quality Q         1..100 for lossy WebP and AVIF          [WebP lossless, AVIF 80]
  --tile-size S       256 | 512                               [256]
  --seed N, --mni M, --marginals gaussian|exemplar, --map NAME, --strength S, --light AZ,EL,
  --encoding terrarium|mapbox, --height_scale METRES (elevation tiles of --map height)
                      the noise, as the tile URLs take them (api/README.md "HTTP API")
  --png-compression N zlib level of PNG tiles, 0..9           [0, as serve]
  --jobs N            tiles rendered at once, 1..64           [one per core]
  --backend B         auto | cpu | osmesa | egl               [auto]
  --quiet             no progress bar
Prints a JSON summary on stdout. Exit status 130 when interrupted (the work done is kept).
)";

std::atomic<bool> g_interrupted{false};
// The first Ctrl-C stops the export cleanly; a second one (the default handler again) kills it.
extern "C" void on_interrupt(int sig) {
    g_interrupted = true;
    std::signal(sig, SIG_DFL);
}

struct Options {
    std::string texton, output, archive, ext = "png";
    api::Query query;
    int png_compression = 0, jobs = 1, tile_size = 256;
    render::BackendKind backend = render::BackendKind::automatic;
    bool quiet = false;
};

struct Encoded {
    TileAddress at;
    std::string bytes;
};

// What tiles of the plan are, for the resume check: everything that changes a byte.
nlohmann::json export_identity(const Options& o, const ExportPlan& plan, const std::string& id,
                               const render::Renderer& renderer) {
    nlohmann::json query = nlohmann::json::object();
    for (const auto& [k, v] : o.query) query[k] = v;
    return {{"texton", id},
            {"noise", render::kNoiseVersion},
            {"renderer", renderer.identity()},
            {"tile_format", o.ext},
            {"query", query},
            {"png_compression", o.png_compression},
            {"tile_size", plan.tile_size},
            {"zooms", {plan.min_zoom, plan.max_zoom}},
            {"bbox", {plan.x0, plan.y0, plan.x1, plan.y1}},
            {"level_of_zoom", "level = 24 - zoom"}};
}

Result<Options> options_from(const Args& a) {
    Options o;
    if (a.positional.size() != 1)
        return make_error(ErrorCode::invalid_argument, "export takes one TEXTON (export --help)");
    o.texton = a.positional[0];
    o.output = a.get("--output");
    if (o.output.empty())
        return make_error(ErrorCode::invalid_argument,
                          "export needs -o OUT.mbtiles or OUT.pmtiles");
    const auto dir = std::filesystem::path(o.output).parent_path();
    if (std::error_code ec; !dir.empty() && !std::filesystem::is_directory(dir, ec))
        return make_error(ErrorCode::invalid_argument,
                          "-o " + o.output + ": no directory " + dir.string());
    for (const char* required : {"--zooms", "--bbox"})
        if (!a.has(required))
            return make_error(ErrorCode::invalid_argument,
                              std::string("export needs ") + required + " (export --help)");
    const std::string ext = std::filesystem::path(o.output).extension().string();
    o.archive = a.get("--format", ext.empty() ? "" : ext.substr(1));
    if (o.archive != "mbtiles" && o.archive != "pmtiles")
        return make_error(ErrorCode::invalid_argument,
                          "--format is mbtiles or pmtiles (or name OUT so), not '" + o.archive +
                              "'");
    o.ext = a.get("--tile-format", "png");
    if (o.ext != "png" && o.ext != "png16" && o.ext != "webp" && o.ext != "avif")
        return make_error(ErrorCode::invalid_argument,
                          "--tile-format is png, png16, webp or avif, not '" + o.ext + "'");
    std::vector<std::string> fields = api::noise_field_names(api::kTileRoute);
    fields.emplace_back("quality");
    for (const std::string& f : fields)
        if (a.has("--" + f)) o.query.emplace(f, a.get("--" + f));
    auto size = a.get_int("--tile-size", 256, 256, 512);
    if (!size || (size.value() != 256 && size.value() != 512))
        return make_error(ErrorCode::invalid_argument, "--tile-size is 256 or 512");
    o.tile_size = static_cast<int>(size.value());
    o.query.emplace("size", std::to_string(o.tile_size));
    auto level = a.get_int("--png-compression", 0, 0, 9);
    if (!level) return level.error();
    o.png_compression = static_cast<int>(level.value());
    const long long cores = std::max(1U, std::thread::hardware_concurrency());
    auto jobs = a.get_int("--jobs", std::min(cores, 64LL), 1, 64);
    if (!jobs) return jobs.error();
    o.jobs = static_cast<int>(jobs.value());
    auto kind = render::parse_backend_kind(a.get("--backend", "auto"));
    if (!kind) return kind.error();
    o.backend = kind.value();
    o.quiet = a.flags.count("--quiet") > 0;
    return o;
}

// What every worker reads: the texton, its id and the renderer.
struct Context {
    const Options& o;
    std::string id;
    app::PreparedTextonResult set;
    render::Renderer& renderer;
};

// One tile as /v1/textons/{id}/map/{z}/{x}/{y}.{ext} would answer it: the API's own parsing,
// view and encoder.
Result<Encoded> render_tile(const Context& c, TileAddress t) {
    api::TileRequest r;
    if (auto e = api::parse_map_tile(c.id, std::to_string(t.z), std::to_string(t.x),
                                     std::to_string(t.y), c.o.ext, c.o.query, r))
        return make_error(ErrorCode::invalid_argument, e->message);
    render::NoiseRequest q =
        app::to_noise_request(r.level, r.x0(), r.y0(), r.size, r.size, r.noise);
    q.precision =
        r.format == api::ImageFormat::png16 ? render::Precision::u16 : render::Precision::u8;
    q.bytes = q.precision == render::Precision::u8;
    auto image =
        app::render_view(c.renderer, c.set, r.noise.map, q, render::Renderer::Work::tile, nullptr);
    if (!image) return image.error();
    auto bytes =
        app::encode_image(std::move(image.value()), r.format, r.quality, c.id, c.o.png_compression);
    if (!bytes) return bytes.error();
    return Encoded{t, std::move(bytes.value())};
}

std::uint64_t packed(int z, std::uint32_t x, std::uint32_t y) {
    return (std::uint64_t(z) << 58) | (std::uint64_t(x) << 29) | y; // x, y < 2^24
}

// OUT.partial: new (its schema and the export's identity written in one go), or a partial of
// this same export, resumed. Anything else there is refused before a byte of it changes.
Result<std::unique_ptr<io::Mbtiles>> open_spool(const std::string& path,
                                                const nlohmann::json& identity) {
    std::error_code ec;
    // A link (even a dangling one) would have the database written wherever it points, outside
    // the output's directory, and OUT become the link: refused like any foreign file.
    const auto status = std::filesystem::symlink_status(path, ec);
    if (!ec && status.type() != std::filesystem::file_type::not_found &&
        status.type() != std::filesystem::file_type::regular)
        return make_error(ErrorCode::invalid_argument,
                          path + " is not a regular file (a link or a directory): move it away, "
                                 "or write to another -o");
    if (!std::filesystem::exists(path, ec) || std::filesystem::file_size(path, ec) == 0) {
        return io::Mbtiles::create(path, true, {{"textond", identity.dump()}});
    }
    auto spool = io::Mbtiles::open(path, true);
    if (!spool) return spool.error();
    auto stored = spool.value()->metadata("textond");
    if (!stored && stored.error().code == ErrorCode::unavailable) return stored.error();
    if (!stored)
        return make_error(ErrorCode::invalid_argument,
                          path + " is not a partial textond export (" + stored.error().message +
                              "): move it away, or write to another -o");
    if (stored.value() != identity.dump())
        return make_error(ErrorCode::invalid_argument,
                          path + " is an export with other options (" + stored.value() +
                              "): run that command again to finish it, or remove " + path);
    return spool;
}

// The plan's tiles that the spool does not hold yet.
Result<std::vector<TileAddress>> tiles_to_do(io::Mbtiles& spool, const ExportPlan& plan) {
    auto keys = spool.keys();
    if (!keys) return keys.error();
    std::unordered_set<std::uint64_t> done;
    for (const auto& k : keys.value()) done.insert(packed(k.z, k.x, k.y));
    std::vector<TileAddress> todo;
    for (const TileAddress& t : plan.tiles())
        if (!done.count(packed(t.z, t.x, t.y))) todo.push_back(t);
    return todo;
}

// Workers render and encode; the caller's thread stores (SQLite takes one writer). At most 4
// tiles a worker and 64 MiB wait to be stored, so a slow disk cannot fill memory.
class TileQueue {
public:
    explicit TileQueue(std::size_t capacity) : m_capacity(capacity) {}
    // false once the consumer has stopped
    bool push(Encoded e) {
        std::unique_lock lock(m_mutex);
        m_not_full.wait(lock, [&] {
            return m_items.empty() || (m_items.size() < m_capacity && m_bytes < kMaxBytes) ||
                   m_stopped;
        });
        if (m_stopped) return false;
        m_bytes += e.bytes.size();
        m_items.push_back(std::move(e));
        m_not_empty.notify_one();
        return true;
    }
    enum class Popped { tile, idle, finished };
    // A tile, or idle after `wait` without one, or finished once every producer is done and
    // nothing is left.
    Popped pop(Encoded& out, std::chrono::milliseconds wait) {
        std::unique_lock lock(m_mutex);
        if (!m_not_empty.wait_for(lock, wait, [&] { return !m_items.empty() || m_producers == 0; }))
            return Popped::idle;
        if (m_items.empty()) return Popped::finished;
        out = std::move(m_items.front());
        m_items.pop_front();
        m_bytes -= out.bytes.size();
        m_not_full.notify_one();
        return Popped::tile;
    }
    void add_producer() {
        std::lock_guard lock(m_mutex);
        ++m_producers;
    }
    void producer_done() {
        std::lock_guard lock(m_mutex);
        --m_producers;
        m_not_empty.notify_all();
    }
    void stop() {
        std::lock_guard lock(m_mutex);
        m_stopped = true;
        m_not_full.notify_all();
    }

private:
    static constexpr std::size_t kMaxBytes = std::size_t{64} << 20;
    std::mutex m_mutex;
    std::condition_variable m_not_full, m_not_empty;
    std::deque<Encoded> m_items;
    std::size_t m_capacity, m_bytes = 0;
    int m_producers = 0;
    bool m_stopped = false;
};

struct RunState {
    std::atomic<std::size_t> next{0};
    std::mutex error_mutex;
    std::optional<Error> error;
    void fail(Error e) {
        std::lock_guard lock(error_mutex);
        if (!error) error = std::move(e);
    }
    bool failed() {
        std::lock_guard lock(error_mutex);
        return error.has_value();
    }
};

void work(const Context& c, const std::vector<TileAddress>& todo, TileQueue& queue,
          RunState& state) {
    for (std::size_t i; (i = state.next++) < todo.size();) {
        if (g_interrupted || state.failed()) break;
        auto tile = render_tile(c, todo[i]);
        if (!tile) {
            state.fail(tile.error());
            break;
        }
        if (!queue.push(std::move(tile.value()))) break;
    }
    queue.producer_done();
}

// Stores what the workers make, committing about once a second (also while renders are slow):
// a kill loses at most that.
Result<std::uint64_t> store_tiles(io::Mbtiles& spool, TileQueue& queue, ProgressBar& bar,
                                  std::uint64_t done) {
    using Clock = std::chrono::steady_clock;
    if (auto b = spool.begin(); !b) return b.error();
    auto committed = Clock::now();
    std::size_t pending = 0;
    Encoded tile;
    for (;;) {
        const auto popped = queue.pop(tile, std::chrono::milliseconds(200));
        if (popped == TileQueue::Popped::finished) break;
        if (popped == TileQueue::Popped::tile) {
            if (auto w = spool.put(tile.at.z, tile.at.x, tile.at.y, tile.bytes); !w)
                return w.error();
            bar.update(++done);
            ++pending;
        }
        if (pending >= 256 || (pending > 0 && Clock::now() - committed > std::chrono::seconds(1))) {
            if (auto w = spool.commit(); !w) return w.error();
            io::crash_point("export-committed");
            if (auto b = spool.begin(); !b) return b.error();
            committed = Clock::now();
            pending = 0;
        }
    }
    if (auto w = spool.commit(); !w) return w.error();
    return done;
}

// Renders `todo` on o.jobs threads into the spool; the number of tiles the spool then holds.
Result<std::uint64_t> run_tiles(const Context& c, const std::vector<TileAddress>& todo,
                                io::Mbtiles& spool, ProgressBar& bar, std::uint64_t done) {
    TileQueue queue(4 * static_cast<std::size_t>(c.o.jobs));
    RunState state;
    std::vector<std::thread> workers;
    Result<std::uint64_t> stored = done;
    try {
        for (int i = 0; i < c.o.jobs; ++i) {
            queue.add_producer();
            workers.emplace_back([&] { work(c, todo, queue, state); });
        }
    } catch (const std::system_error& e) { // the system's thread limit
        queue.producer_done();
        state.fail({ErrorCode::unavailable,
                    std::string("cannot start a worker: ") + e.what() + " (try fewer --jobs)"});
    }
    if (!state.failed()) stored = store_tiles(spool, queue, bar, done);
    queue.stop();
    for (auto& w : workers) w.join();
    if (!stored) return stored.error();
    if (state.error) return *state.error;
    return stored.value();
}

// The spec's metadata rows (MBTiles 1.3) or JSON (PMTiles), the same names in both.
nlohmann::json archive_metadata(const Options& o, const ExportPlan& plan, const std::string& id,
                                const nlohmann::json& identity) {
    const std::vector<double> b = plan.bounds_degrees();
    const std::string format = o.ext == "png16" ? "png" : o.ext == "avif" ? "image/avif" : o.ext;
    return {{"name", "textond " + id.substr(0, 12)},
            {"description", "texton noise of texton " + id + " (textond export)"},
            {"format", format},
            {"type", "baselayer"},
            {"version", "1"},
            {"minzoom", plan.min_zoom},
            {"maxzoom", plan.max_zoom},
            {"bounds", b},
            {"center", {(b[0] + b[2]) / 2, (b[1] + b[3]) / 2, plan.center_zoom()}},
            {"textond", identity}};
}

std::string joined(const nlohmann::json& numbers) {
    std::string s;
    for (const auto& v : numbers) s += (s.empty() ? "" : ",") + v.dump();
    return s;
}

// The spool becomes the MBTiles file: its metadata rows, then a rename.
Result<bool> finish_mbtiles(std::unique_ptr<io::Mbtiles> spool, const std::string& partial,
                            const std::string& output, const nlohmann::json& meta) {
    for (const auto& [name, value] : meta.items()) {
        const std::string text = value.is_string()  ? value.get<std::string>()
                                 : value.is_array() ? joined(value)
                                                    : value.dump();
        if (auto w = spool->set_metadata(name, text); !w) return w.error();
    }
    if (auto c = spool->close(); !c) return c.error();
    std::error_code ec;
    std::filesystem::rename(partial, output, ec);
    if (ec)
        return make_error(ErrorCode::io,
                          "cannot rename " + partial + " to " + output + ": " + ec.message());
    return true;
}

// The spool's tiles, in tile-id order, behind a PMTiles header and directories.
Result<bool> finish_pmtiles(std::unique_ptr<io::Mbtiles> spool, const std::string& partial,
                            const std::string& output, const nlohmann::json& meta, const Options& o,
                            const ExportPlan& plan) {
    namespace pm = io::pmtiles;
    auto keys = spool->keys();
    if (!keys) return keys.error();
    std::vector<pm::Tile> tiles;
    for (const auto& k : keys.value()) tiles.push_back({k.z, k.x, k.y, k.length});
    pm::Header h;
    h.tile_type = o.ext == "webp"   ? pm::TileType::webp
                  : o.ext == "avif" ? pm::TileType::avif
                                    : pm::TileType::png;
    h.min_zoom = plan.min_zoom;
    h.max_zoom = plan.max_zoom;
    h.center_zoom = plan.center_zoom();
    const std::vector<double> b = plan.bounds_degrees();
    h.min_lon = b[0], h.min_lat = b[1], h.max_lon = b[2], h.max_lat = b[3];
    h.center_lon = (b[0] + b[2]) / 2, h.center_lat = (b[1] + b[3]) / 2;
    auto written = pm::write_archive(output, h, meta.dump(), tiles, [&](std::size_t i) {
        if (g_interrupted) // the temporary goes; the partial stays for the next run
            return Result<std::string>(make_error(ErrorCode::cancelled, "interrupted"));
        return spool->get(tiles[i].z, tiles[i].x, tiles[i].y);
    });
    if (!written) return written.error();
    if (auto c = spool->close(); !c) return c.error();
    std::error_code ec;
    std::filesystem::remove(partial, ec); // the archive is whole; a stale partial only costs disk
    return true;
}

// SIGINT and SIGTERM stop the export cleanly while it lives (on_interrupt).
struct InterruptHandlers {
    InterruptHandlers()
        : old_int(std::signal(SIGINT, on_interrupt)), old_term(std::signal(SIGTERM, on_interrupt)) {
        g_interrupted = false;
    }
    ~InterruptHandlers() {
        std::signal(SIGINT, old_int);
        std::signal(SIGTERM, old_term);
    }
    InterruptHandlers(const InterruptHandlers&) = delete;
    InterruptHandlers& operator=(const InterruptHandlers&) = delete;
    void (*old_int)(int);
    void (*old_term)(int);
};

int interrupted(std::uint64_t stored, std::uint64_t total, const std::string& partial) {
    return fail(130, "interrupted: " + std::to_string(stored) + " of " + std::to_string(total) +
                         " tiles are in " + partial + "; run the same command again to resume");
}

int run_export(const Context& c, const ExportPlan& plan) {
    const Options& o = c.o;
    const std::string partial = o.output + ".partial";
    const nlohmann::json identity = export_identity(o, plan, c.id, c.renderer);
    auto spool = open_spool(partial, identity);
    if (!spool) return fail(1, spool.error().message);
    auto todo = tiles_to_do(*spool.value(), plan);
    if (!todo) return fail(1, todo.error().message);
    const std::uint64_t total = plan.count(), before = total - todo.value().size();
    if (before > 0)
        spdlog::info("resuming: {} of {} tiles are already in {}", before, total, partial);
    const auto t0 = std::chrono::steady_clock::now();
    ProgressBar bar("export", total, before, o.quiet);
    const InterruptHandlers handlers;
    auto stored = run_tiles(c, todo.value(), *spool.value(), bar, before);
    bar.finish();
    if (!stored)
        return fail(1, stored.error().message + " (tiles done so far are kept in " + partial + ")");
    if (stored.value() < total) return interrupted(stored.value(), total, partial);
    const nlohmann::json meta = archive_metadata(o, plan, c.id, identity);
    auto finished =
        o.archive == "mbtiles"
            ? finish_mbtiles(std::move(spool.value()), partial, o.output, meta)
            : finish_pmtiles(std::move(spool.value()), partial, o.output, meta, o, plan);
    if (!finished && finished.error().code == ErrorCode::cancelled)
        return interrupted(total, total, partial);
    if (!finished) return fail(1, finished.error().message);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::error_code ec;
    const auto bytes = std::filesystem::file_size(o.output, ec);
    const nlohmann::json summary = {
        {"output", o.output},
        {"format", o.archive},
        {"tiles", total},
        {"resumed_with", before},
        {"rendered", todo.value().size()},
        {"bytes", ec ? 0 : bytes},
        {"seconds", s},
        {"tiles_per_s", s > 0 ? static_cast<double>(todo.value().size()) / s : 0.0},
        {"backend", c.renderer.tiles_backend()}};
    std::printf("%s\n", summary.dump(2).c_str());
    return 0;
}

} // namespace

int export_command(const Argv& argv) {
    // The noise options are the tile URL's noise fields (api/noise_fields.h), checked by the
    // tile parser itself.
    std::set<std::string> options = {
        "--zooms",   "--bbox",      "--format",          "--output", "--tile-format",
        "--quality", "--tile-size", "--png-compression", "--jobs",   "--backend"};
    for (const std::string& f : api::noise_field_names(api::kTileRoute)) options.insert("--" + f);
    auto a = parse_args(argv, options, {"--help", "--quiet"}, true);
    if (!a) return fail(2, a.error().message);
    if (a.value().flags.count("--help")) {
        std::fputs(kHelp, stdout);
        return 0;
    }
    auto o = options_from(a.value());
    if (!o) return fail(2, o.error().message);
    auto plan =
        make_export_plan(a.value().get("--zooms"), a.value().get("--bbox"), o.value().tile_size);
    if (!plan) return fail(2, plan.error().message);
    auto record = io::read_texton_file(o.value().texton);
    if (!record) return fail(1, o.value().texton + ": " + record.error().message);
    render::BackendOptions bo;
    bo.tile_slots = o.value().jobs;
    auto renderer = render::Renderer::make(o.value().backend, bo);
    if (!renderer) return fail(1, renderer.error().message);
    const std::string id = record.value().meta.id;
    const Context c{o.value(), id, render::PreparedTexton::make(std::move(record.value().texton)),
                    *renderer.value()};
    // The first tile, before any file is touched: bad options fail here, in the API's words.
    const ExportPlan::Zoom& first = plan.value().zooms.front();
    if (auto probe = render_tile(c, {first.z, first.x0, first.y0}); !probe)
        return fail(probe.error().code == ErrorCode::invalid_argument ? 2 : 1,
                    probe.error().message);
    return run_export(c, plan.value());
}

} // namespace textond::cli
