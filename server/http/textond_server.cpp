#include "server/http/textond_server.h"
#include "render/table_budget.h"

#include "api/query_text.h"

#include "api/openapi_spec.h"
#include "api/safe_text.h"
#include "core/texton_analysis.h"
#include "render/backend_factory.h"
#include "render/noise_request.h"
#include "server/http/config.h"
#include "server/http/framing.h"
#include "server/http/request_context.h"
#include "server/http/responses.h"
#include "server/io/image_io.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sys/socket.h>
#include <thread>

namespace textond::http {

namespace {
int cores() {
    const unsigned n = std::thread::hardware_concurrency();
    return n == 0 ? 1 : static_cast<int>(n);
}

// CORS: "*", or one of the listed origins (echoed, with Vary: Origin); none when `listed` is
// empty and `any` is false.
void apply_cors(bool any, const std::vector<std::string>& listed, const httplib::Request& req,
                httplib::Response& res) {
    if (any) {
        res.set_header("Access-Control-Allow-Origin", "*");
    } else {
        if (listed.empty()) return;
        res.set_header("Vary", "Origin");
        const std::string origin = req.get_header_value("Origin");
        if (std::find(listed.begin(), listed.end(), origin) == listed.end()) return;
        res.set_header("Access-Control-Allow-Origin", origin);
    }
    res.set_header(
        "Access-Control-Expose-Headers",
        "ETag, X-Request-Id, Location, Retry-After, X-Textond-Backend, X-Textond-Channels");
}
} // namespace

TextondServer::TextondServer(ServeConfig config)
    : m_config(std::move(config)), m_cache(m_config.cache_bytes), m_gate(m_config, m_metrics),
      m_cors_any(m_config.cors_origin == "*"),
      m_cors_origins(m_cors_any ? std::vector<std::string>{} : split_list(m_config.cors_origin)) {
    render::TableBudget::instance().set_limit(m_config.table_cache_bytes);
}

TextondServer::~TextondServer() {
    stop();
    if (m_pool) m_pool->shutdown();
}

Result<std::unique_ptr<TextondServer>> TextondServer::create(ServeConfig config) {
    std::unique_ptr<TextondServer> s(new TextondServer(std::move(config)));
    if (auto err = s->open_parts()) return *err;
    s->make_services();
    s->add_gauges();
    s->install_hooks();
    s->install_routes();
    return s;
}

std::optional<Error> TextondServer::open_parts() {
    std::unique_ptr<store::RedisStore> shared;
    if (!m_config.store_url.empty()) {
        auto address = store::parse_redis_url(m_config.store_url);
        if (!address) return address.error();
        shared = std::make_unique<store::RedisStore>(
            address.value(), std::chrono::milliseconds(m_config.store_timeout_ms));
        if (auto up = shared->up(); !up) // not fatal: local copies can still be served
            spdlog::warn("{}; starting anyway", up.error().message);
    }
    auto store = TextonStore::open(m_config.data_dir, 64, std::move(shared),
                                   std::chrono::milliseconds(1000LL * m_config.store_recheck_s),
                                   static_cast<std::size_t>(m_config.meta_cache));
    if (!store) return store.error();
    m_store = std::move(store.value());
    const std::chrono::milliseconds recheck(1000LL * m_config.store_recheck_s);
    auto mixes = MixStore::open(m_config.data_dir, m_store->shared(), recheck);
    if (!mixes) return mixes.error();
    m_mixes = std::move(mixes.value());
    auto splats = SplatStore::open(m_config.data_dir, *m_store, recheck);
    if (!splats) return splats.error();
    m_splats = std::move(splats.value());

    render::BackendOptions options;
    options.threads = 0;
    options.tile_slots = m_config.render_slots > 0 ? m_config.render_slots : cores();
    options.batch_tiles = m_config.gpu_batch_tiles;
    options.batch_wait_us = m_config.gpu_batch_wait_us;
    options.batch_ms = m_config.gpu_batch_ms;
    options.gl_lanes = m_config.gpu_lanes;
    auto renderer = render::Renderer::make(m_config.backend, options);
    if (!renderer) return renderer.error();
    m_renderer = std::move(renderer.value());
    m_gate.set_work_factor(m_renderer->work_factor());
    // Tiles on a GL backend: a slot mostly waits for its batch, so one per core would never fill
    // one. Enough more to gather a whole batch a lane while the cores encode the last.
    // Only when frames go there too: CPU frames and fallbacks would take the extra slots.
    if (m_config.render_slots == 0 && m_renderer->all_batched())
        m_gate.render_slots().add(m_config.gpu_batch_tiles * m_renderer->gl_lanes());
    m_pool = std::make_unique<AnalysisPool>(m_config.analysis_workers, m_config.analysis_queue);
    return std::nullopt;
}

void TextondServer::make_services() {
    io::DecodeLimits limits;
    limits.max_pixels = m_config.max_pixels;
    limits.formats = m_config.formats;
    m_textons = std::make_unique<TextonService>(
        *m_store, *m_pool, m_metrics, m_gate.decode_slots(), std::move(limits),
        std::chrono::milliseconds(m_config.queue_timeout_ms), m_config.max_request_cpu_s);
    m_mix_service = std::make_unique<MixService>(*m_store, *m_mixes, *m_pool);
    m_splat_service = std::make_unique<SplatService>(*m_splats);
    auto textons = std::make_unique<TextonSource>(*m_store, *m_renderer, m_metrics);
    m_texton_source = textons.get();
    m_sources.push_back(std::move(textons));
    m_sources.push_back(std::make_unique<MixSource>(*m_mixes, *m_renderer, m_metrics));
    m_sources.push_back(std::make_unique<SplatSource>(*m_splats, *m_renderer, m_metrics));
    m_images =
        std::make_unique<ImageService>(*m_texton_source, *m_renderer, m_config.png_compression);
    m_image_routes = std::make_unique<ImageRoutes>(m_config, *m_images, *m_texton_source, m_cache,
                                                   m_gate, m_metrics, m_port);
    m_texton_routes = std::make_unique<TextonRoutes>(m_config, *m_store, *m_textons, *m_pool,
                                                     m_cache, m_gate, m_stopping);
    m_mix_routes =
        std::make_unique<MixRoutes>(m_config, *m_mix_service, *m_mixes, *m_pool, m_cache, m_gate);
    m_splat_routes =
        std::make_unique<SplatRoutes>(m_config, *m_splat_service, *m_splats, m_cache, m_gate);
    m_surfaces = std::make_unique<SurfaceService>(*m_renderer);
    m_surface_routes =
        std::make_unique<SurfaceRoutes>(*m_store, *m_surfaces, m_gate, m_config.api_key);
    m_sign_routes = std::make_unique<SignRoutes>(m_config, m_gate);
    m_ops_routes = std::make_unique<OpsRoutes>(m_config, m_metrics, *m_store, *m_mixes, *m_splats,
                                               *m_renderer, m_stopping);
}

void TextondServer::add_gauges() {
    Metrics& m = m_metrics;
    std::vector<Metrics::CalibrationFigure> figures;
    for (const auto& c : m_renderer->calibration())
        figures.push_back({c.backend, c.tile_ms, c.frame_ms});
    m.backends(m_renderer->tiles_backend(), m_renderer->frames_backend(), std::move(figures));
    auto count = [](auto f) { return [f] { return static_cast<double>(f()); }; };
    const render::Renderer* r = m_renderer.get();
    m.gauge("textond_gpu_batches", "GL batches rendered since start (0 without a GL backend).",
            count([r] { return r->batches(); }));
    m.gauge("textond_gpu_batched_windows", "Windows rendered in GL batches since start.",
            count([r] { return r->batched_windows(); }));
    m.gauge("textond_gpu_lanes", "GL batch workers, each with a context (0 without a GL backend).",
            count([r] { return r->gl_lanes(); }));
    const WorkSlots* slots = &m_gate.render_slots();
    m.gauge("textond_render_waiting", "Renders waiting for a render slot.",
            count([slots] { return slots->waiting(); }));
    m.gauge("textond_render_slots_free", "Render slots no render holds now.",
            count([slots] { return slots->free(); }));
    const AnalysisPool* pool = m_pool.get();
    m.gauge("textond_analysis_queue_depth", "Analyses waiting for a worker.",
            count([pool] { return pool->queued(); }));
    m.gauge("textond_analysis_running", "Analyses running now.",
            count([pool] { return pool->running(); }));
    TextonStore* store = m_store.get();
    if (store->shared())
        // RedisStore::health, as /readyz reads it: an alert on the metric and a look at the
        // readiness agree, and a full or evicting Redis counts as down.
        m.gauge("textond_shared_store_up",
                "1 when the shared store answers PING, took its last minute's writes and has "
                "room (not nearly full, not evicting): 0 exactly when /readyz says degraded.",
                [store] { return store->shared()->health().problem ? 0.0 : 1.0; });
    m.gauge("textond_store_textons", "Textons held in the local store (or cache).",
            count([store] { return store->local().count(); }));
    m.gauge("textond_store_bytes", "Bytes of texton files in the store.",
            count([store] { return store->local().bytes(); }));
    m.gauge("textond_store_quarantined", "Damaged texton files in the quarantine directory.",
            count([store] { return store->local().quarantined_count(); }));
    const MixStore* mixes = m_mixes.get();
    m.gauge("textond_mixes_quarantined",
            "Mixes refused at load (damaged or invalid), in quarantine.",
            count([mixes] { return mixes->quarantined_count(); }));
    const SplatStore* splats = m_splats.get();
    m.gauge("textond_splats_quarantined",
            "Splats refused at load (damaged or invalid), in quarantine.",
            count([splats] { return splats->quarantined_count(); }));
    const ImageCache* cache = &m_cache;
    m.gauge("textond_image_cache_bytes", "Bytes held by the image cache.",
            count([cache] { return cache->bytes(); }));
    m.gauge("textond_image_cache_entries", "Images held by the image cache.",
            count([cache] { return cache->entries(); }));
    m.gauge("textond_image_cache_budget_bytes", "The image cache's byte budget.",
            count([cache] { return cache->budget(); }));
    m.gauge("textond_table_cache_bytes",
            "Bytes of level tables and covariances kept for prepared textons (--table-cache-mb).",
            count([] { return render::TableBudget::instance().bytes(); }));
}

namespace {

// The server's limits: threads, connections, timeouts, header and body sizes.
void configure(HttpServer& http, const ServeConfig& c) {
    const std::size_t threads = static_cast<std::size_t>(c.http_threads < 1 ? 1 : c.http_threads);
    const std::size_t most = static_cast<std::size_t>(std::max(c.max_connections, 1));
    // Debian's prebuilt cpp-httplib ignores CPPHTTPLIB_THREAD_POOL_COUNT in our code.
    http.new_task_queue = [&http, threads, most] {
        auto* pool = new ElasticThreadPool(threads, most);
        http.crowd = [pool] { return pool->crowd(); };
        return pool;
    };
    http.set_payload_max_length(c.max_upload_bytes);
    http.set_read_timeout(c.read_timeout_s, 0);
    http.set_write_timeout(c.write_timeout_s, 0);
    http.set_keep_alive_max_count(static_cast<std::size_t>(c.keep_alive_max));
    http.set_keep_alive_timeout(c.keep_alive_timeout_s);
    ConnectionLimits& limits = http.limits;
    limits.max_header_bytes = c.max_header_bytes;
    limits.header_timeout = std::chrono::seconds(c.header_timeout_s);
    // The routes count the decoded body exactly; this bounds the bytes on the wire (chunk
    // framing included) for the bodies the library reads itself.
    limits.max_body_bytes = c.max_upload_bytes + c.max_upload_bytes / 8 + 64 * 1024;
    limits.body_timeout = std::chrono::seconds(c.body_timeout_s);
    limits.read_timeout = std::chrono::seconds(c.read_timeout_s);
    limits.write_timeout = std::chrono::seconds(c.write_timeout_s);
    limits.keep_alive_timeout = std::chrono::seconds(c.keep_alive_timeout_s);
    limits.keep_alive_max = c.keep_alive_max;
}

// Ranges are for resuming and seeking, not for sending one image many times over (500 copies of
// a whole tile in one answer): at most kMaxRanges, and several only when none overlaps and each
// has both ends (a suffix or open range overlaps whatever follows it).
constexpr std::size_t kMaxRanges = 16;
bool ranges_allowed(const httplib::Ranges& ranges) {
    if (ranges.size() > kMaxRanges) return false;
    if (ranges.size() < 2) return true;
    auto sorted = ranges;
    for (const auto& [first, last] : sorted)
        if (first < 0 || last < 0) return false;
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t i = 1; i < sorted.size(); ++i)
        if (sorted[i].first <= sorted[i - 1].second) return false;
    return true;
}

// Every answer: no MIME sniffing, no referrer leaving with a signed URL, and the page (which
// holds an API key field) neither framed by another site nor running any script but its own.
void apply_security_headers(httplib::Response& res) {
    for (const auto& [name, value] : security_headers()) res.set_header(name, value);
}

httplib::Server::HandlerResponse answer_http_error(const httplib::Request& req,
                                                   httplib::Response& res) {
    // An error is answered whole. The library keeps the ranges it read before a bad one
    // (`bytes=0-5,5-2`) and would cut this body into them; pre_route, which caps and clears
    // ranges, has not run.
    const_cast<httplib::Request&>(req).ranges.clear();
    if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
    api::ApiError e{"http_error", "HTTP error " + std::to_string(res.status)};
    close_after_library_error(res.status);
    if (res.status == 400) e = {"bad_request", "malformed HTTP request"};
    if (res.status == 404) e = {"not_found", "no such endpoint"};
    if (res.status == 413) e = {"payload_too_large", "request body is over the upload limit"};
    if (res.status == 414) e = {"uri_too_long", "request URI is too long"};
    // cpp-httplib parses Range before any route runs and answers 416 for one it cannot read; the
    // length is not known yet, so no Content-Range can be sent with it.
    if (res.status == 416)
        e = {"range_not_satisfiable",
             "the Range header cannot be read: it must be bytes=FIRST-LAST[,...] with "
             "FIRST <= LAST, or bytes=-SUFFIX (RFC 9110, 14.1.2); send none for the whole "
             "answer"};
    // Any other status keeps cpp-httplib's number under the code http_error.
    send_error(res, e, e.code == "http_error" ? res.status : 0);
    return httplib::Server::HandlerResponse::Handled;
}

void answer_exception(const httplib::Request& req, httplib::Response& res,
                      const std::exception_ptr& ep) {
    std::string what;
    try {
        std::rethrow_exception(ep);
    } catch (const std::exception& e) {
        what = e.what();
    } catch (...) {
        what = "unknown exception";
    }
    spdlog::error("{} {} {}: unhandled exception: {}", current_request().id,
                  api::printable(req.method, 16), api::printable(req.path, 256),
                  api::printable(what, 512));
    send_error(res, {"internal", "internal error (request id " + current_request().id + ")"});
}

} // namespace

httplib::Server::HandlerResponse TextondServer::pre_route(const httplib::Request& req,
                                                          httplib::Response& res) {
    begin_request(req);
    if (auto e = frame_request(req, static_cast<std::size_t>(m_config.max_headers),
                               m_config.max_upload_bytes)) {
        set_route("framing");
        send_error(res, *e);
        return httplib::Server::HandlerResponse::Handled;
    }
    if (auto e = api::check_target_text(req.target)) {
        set_route("query");
        send_error(res, *e);
        return httplib::Server::HandlerResponse::Handled;
    }
    // Ranges past the limit are ignored, as nginx does past max_ranges: the whole answer, once.
    // So is Range on a method other than GET and HEAD, for which RFC 9110 (14.2) defines none.
    if (!ranges_allowed(req.ranges) || (req.method != "GET" && req.method != "HEAD")) {
        current_request().request->ranges.clear();
        current_request().if_range_ranges.clear();
    }
    if (req.method == "OPTIONS") { // CORS preflight
        set_route("OPTIONS *");
        res.status = 204;
        if (!m_config.cors_origin.empty()) {
            res.set_header("Access-Control-Allow-Methods", "GET, HEAD, POST, DELETE, OPTIONS");
            res.set_header(
                "Access-Control-Allow-Headers",
                "Authorization, Content-Type, If-Match, If-None-Match, Prefer, X-Request-Id");
            res.set_header("Access-Control-Max-Age", "600");
        }
        return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
}

void TextondServer::install_hooks() {
    configure(m_http, m_config);
    m_http.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
        return pre_route(req, res);
    });
    m_http.set_post_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
        RequestContext& ctx = current_request();
        ctx.handler_ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - ctx.start)
                .count();
        res.set_header("X-Request-Id", ctx.id);
        // Said on GET as on HEAD (cpp-httplib added it to HEAD answers only): bytes where a
        // Range is honoured (an image, a file, the page; a 304 of one; a 416 says a Range could
        // not be read), none for a JSON answer or an error, always whole. An edge (nginx) serves
        // ranges of what it caches only from an upstream that says so.
        if (req.method == "GET" || req.method == "HEAD") {
            const bool whole = (res.status >= 300 && res.status != 304 && res.status != 416) ||
                               res.get_header_value("Content-Type") == "application/json";
            res.headers.erase("Accept-Ranges");
            res.set_header("Accept-Ranges", whole ? "none" : "bytes");
        }
        apply_cors(m_cors_any, m_cors_origins, req, res);
        apply_security_headers(res);
        announce_close(res);
    });
    // Errors raised before or outside a route (404, 413 from the body limit, 414...) get the
    // same JSON body as ours; bodies a route already wrote are left alone.
    m_http.set_error_handler(httplib::Server::HandlerWithResponse(answer_http_error));
    m_http.set_exception_handler(answer_exception);
    // Answers the connection loop sent itself (the library's request was cut short): logged
    // there, with their real status, and not here as the library's 400.
    m_http.on_connection_error = [this](int status, std::size_t bytes, const std::string& id) {
        m_metrics.request("connection", "-", status, 0.0);
        if (m_config.access_log)
            spdlog::info("{} - - {} {}B (answered by the connection: the request was cut short)",
                         id, status, bytes);
        current_request().active = false;
        current_request().request = nullptr;
    };
    m_http.set_logger([this](const httplib::Request& req, const httplib::Response& res) {
        const ConnectionStream* conn = current_connection();
        if (conn && conn->failure() != ConnectionStream::Failure::none) return;
        RequestContext& ctx = current_request();
        const double seconds =
            ctx.active ? std::chrono::duration<double>(std::chrono::steady_clock::now() - ctx.start)
                             .count()
                       : 0.0;
        m_metrics.request(ctx.route, req.method, res.status, seconds);
        // A client that stopped reading is logged as such, with what it took of the answer.
        const bool left = conn && conn->write_failed();
        if (m_config.access_log)
            spdlog::info("{} {} {} {} {}B {:.2f}ms (handler {:.2f}ms){}", ctx.id,
                         api::printable(req.method, 16), api::printable(req.path, 256), res.status,
                         res.get_header_value("Content-Length"), seconds * 1000.0, ctx.handler_ms,
                         left ? " client left after " + std::to_string(conn->written()) +
                                    "B of the answer"
                              : std::string());
        ctx.active = false;
        ctx.request = nullptr;
    });
}

Result<int> TextondServer::bind() {
    // cpp-httplib 0.11 binds with SO_REUSEPORT alone: a second server on a port in use bound it
    // too, and the kernel split the connections between two processes (perhaps on two data
    // directories) without a word. SO_REUSEADDR alone still binds at once after a restart, past
    // the old socket's TIME_WAIT.
    m_http.set_socket_options([](socket_t sock) {
        const int yes = 1;
        ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    const int port = m_config.port == 0
                         ? m_http.bind_to_any_port(m_config.host)
                         : (m_http.bind_to_port(m_config.host, m_config.port) ? m_config.port : -1);
    if (port < 0)
        return make_error(ErrorCode::io, "cannot listen on " + m_config.host + ":" +
                                             std::to_string(m_config.port) +
                                             " (in use, or not an address of this machine)");
    if (::listen(m_http.listening_socket(), m_config.listen_backlog) != 0)
        spdlog::warn("cannot enlarge the listen backlog to {}", m_config.listen_backlog);
    m_port = port;
    return port;
}

void TextondServer::run() {
    m_http.listen_after_bind();
}

void TextondServer::stop() {
    if (m_stopping.exchange(true)) return;
    m_http.stop();
}

} // namespace textond::http
