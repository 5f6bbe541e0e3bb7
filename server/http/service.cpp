#include "server/http/service.h"

#include "api/openapi_spec.h"
#include "api/safe_text.h"
#include "core/texton_analysis.h"
#include "render/backend_factory.h"
#include "render/noise_request.h"
#include "server/http/http_support.h"
#include "server/io/image_io.h"

#include <OpenImageIO/oiioversion.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sys/socket.h>
#include <thread>

#ifndef TEXTOND_GIT_COMMIT
#define TEXTOND_GIT_COMMIT "unknown"
#endif
#ifndef TEXTOND_WEB_DIR
#define TEXTOND_WEB_DIR "web"
#endif
#ifndef TEXTOND_VERSION
#define TEXTOND_VERSION "0.0.0"
#endif

namespace textond::http {

const std::string& build_id() {
    // The PNG/EXR encoder is part of what produced a tile's bytes, so its version is too.
    static const std::string id = std::string("textond/") + TEXTOND_VERSION + "+" +
                                  TEXTOND_GIT_COMMIT + " " + render::kNoiseVersion + " " +
                                  core::kAnalysisVersion + " oiio/" OIIO_VERSION_STRING;
    return id;
}

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

Service::Service(ServeConfig config)
    : m_config(std::move(config)), m_cache(m_config.cache_bytes), m_gate(m_config, m_metrics),
      m_cors_any(m_config.cors_origin == "*"),
      m_cors_origins(m_cors_any ? std::vector<std::string>{} : split_list(m_config.cors_origin)) {}

Service::~Service() {
    stop();
    if (m_pool) m_pool->shutdown();
}

Result<std::unique_ptr<Service>> Service::create(ServeConfig config) {
    std::unique_ptr<Service> s(new Service(std::move(config)));
    std::unique_ptr<store::RedisStore> shared;
    if (!s->m_config.store_url.empty()) {
        auto address = store::parse_redis_url(s->m_config.store_url);
        if (!address) return address.error();
        shared = std::make_unique<store::RedisStore>(
            address.value(), std::chrono::milliseconds(s->m_config.store_timeout_ms));
        if (auto ping = shared->ping(); !ping) // not fatal: local copies can still be served
            spdlog::warn("{}; starting anyway", ping.error().message);
    }
    auto store = TextonStore::open(s->m_config.data_dir, 64, std::move(shared),
                                   std::chrono::milliseconds(1000LL * s->m_config.store_recheck_s));
    if (!store) return store.error();
    s->m_store = std::move(store.value());

    render::BackendOptions options;
    options.threads = 0;
    options.tile_slots = s->m_config.render_slots > 0 ? s->m_config.render_slots : cores();
    options.batch_tiles = s->m_config.gpu_batch_tiles;
    options.batch_wait_us = s->m_config.gpu_batch_wait_us;
    options.batch_ms = s->m_config.gpu_batch_ms;
    auto renderer = render::Renderer::make(s->m_config.backend, options);
    if (!renderer) return renderer.error();
    s->m_renderer = std::move(renderer.value());
    // Tiles on a GL backend: a slot mostly waits for its batch, so one per core would never fill
    // one. Enough more to gather a whole batch while the cores encode the last.
    // Only when frames go there too: CPU frames and fallbacks would take the extra slots.
    if (s->m_config.render_slots == 0 && s->m_renderer->all_batched())
        s->m_gate.render_slots().add(s->m_config.gpu_batch_tiles);
    s->m_pool =
        std::make_unique<AnalysisPool>(s->m_config.analysis_workers, s->m_config.analysis_queue);
    io::DecodeLimits limits;
    limits.max_pixels = s->m_config.max_pixels;
    limits.formats = s->m_config.formats;
    s->m_textons = std::make_unique<TextonService>(
        *s->m_store, *s->m_pool, s->m_metrics, s->m_gate.decode_slots(), std::move(limits),
        std::chrono::milliseconds(s->m_config.queue_timeout_ms));
    auto mixes = MixStore::open(s->m_config.data_dir);
    if (!mixes) return mixes.error();
    s->m_mixes = std::move(mixes.value());
    s->m_mix_service = std::make_unique<MixService>(*s->m_store, *s->m_mixes, *s->m_pool);

    Metrics& m = s->m_metrics;
    std::vector<Metrics::CalibrationFigure> figures;
    for (const auto& c : s->m_renderer->calibration())
        figures.push_back({c.backend, c.tile_ms, c.frame_ms});
    m.backends(s->m_renderer->tiles_backend(), s->m_renderer->frames_backend(), std::move(figures));
    Service* self = s.get();
    m.gauge("textond_gpu_batches", "GL batches rendered since start (0 without a GL backend).",
            [self] { return static_cast<double>(self->m_renderer->batches()); });
    m.gauge("textond_gpu_batched_windows", "Windows rendered in GL batches since start.",
            [self] { return static_cast<double>(self->m_renderer->batched_windows()); });
    m.gauge("textond_analysis_queue_depth", "Analyses waiting for a worker.",
            [self] { return static_cast<double>(self->m_pool->queued()); });
    m.gauge("textond_analysis_running", "Analyses running now.",
            [self] { return static_cast<double>(self->m_pool->running()); });
    if (self->m_store->shared())
        m.gauge("textond_shared_store_up", "1 when the shared texton store answers a PING.",
                [self] { return self->m_store->shared()->ping() ? 1.0 : 0.0; });
    m.gauge("textond_store_textons", "Textons held in the local store (or cache).",
            [self] { return static_cast<double>(self->m_store->count()); });
    m.gauge("textond_store_bytes", "Bytes of texton files in the store.",
            [self] { return static_cast<double>(self->m_store->bytes()); });
    m.gauge("textond_store_quarantined", "Damaged texton files moved aside since start.",
            [self] { return static_cast<double>(self->m_store->quarantined().size()); });
    m.gauge("textond_mixes_quarantined", "Mixes refused at load (damaged or invalid) since start.",
            [self] { return static_cast<double>(self->m_mixes->quarantined().size()); });
    m.gauge("textond_image_cache_bytes", "Bytes held by the image cache.",
            [self] { return static_cast<double>(self->m_cache.bytes()); });
    m.gauge("textond_image_cache_entries", "Images held by the image cache.",
            [self] { return static_cast<double>(self->m_cache.entries()); });
    m.gauge("textond_image_cache_budget_bytes", "The image cache's byte budget.",
            [self] { return static_cast<double>(self->m_cache.budget()); });

    s->install_hooks();
    s->install_image_routes();   // the hot path first: cpp-httplib tries routes in order
    s->install_surface_routes(); // before the /v1/textons/* fallback
    s->install_texton_routes();
    s->install_mix_routes();
    s->install_ops_routes();
    s->install_web_routes();
    return s;
}

void Service::install_hooks() {
    const ServeConfig& c = m_config;
    const std::size_t threads = static_cast<std::size_t>(c.http_threads < 1 ? 1 : c.http_threads);
    const std::size_t most = static_cast<std::size_t>(std::max(c.max_connections, 1));
    // Debian's prebuilt cpp-httplib ignores CPPHTTPLIB_THREAD_POOL_COUNT in our code.
    m_http.new_task_queue = [threads, most] { return new ElasticThreadPool(threads, most); };
    m_http.set_payload_max_length(c.max_upload_bytes);
    m_http.set_read_timeout(c.read_timeout_s, 0);
    m_http.set_write_timeout(c.write_timeout_s, 0);
    m_http.set_keep_alive_max_count(static_cast<std::size_t>(c.keep_alive_max));
    m_http.set_keep_alive_timeout(c.keep_alive_timeout_s);
    ConnectionLimits& limits = m_http.limits;
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

    m_http.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
        begin_request(req);
        ConnectionStream* conn = current_connection();
        if (conn) conn->begin_body();
        if (auto e = check_framing(req, static_cast<std::size_t>(m_config.max_headers))) {
            set_route("framing");
            if (conn) conn->close_after_response(); // its body, if any, is still on the wire
            send_error(res, *e);
            return httplib::Server::HandlerResponse::Handled;
        }
        // Over the limit by its own account: answered before a byte of it is read (cpp-httplib
        // would read and discard it all first), and the connection closed after the answer.
        if (req.has_header("Content-Length") &&
            std::strtoull(req.get_header_value("Content-Length").c_str(), nullptr, 10) >
                m_config.max_upload_bytes) {
            set_route("framing");
            if (conn) conn->close_after_response();
            send_error(res, {"payload_too_large", "request body is over the upload limit of " +
                                                      std::to_string(m_config.max_upload_bytes) +
                                                      " bytes"});
            return httplib::Server::HandlerResponse::Handled;
        }
        if (req.method == "OPTIONS") { // CORS preflight
            set_route("OPTIONS *");
            res.status = 204;
            if (!m_config.cors_origin.empty()) {
                res.set_header("Access-Control-Allow-Methods", "GET, HEAD, POST, DELETE, OPTIONS");
                res.set_header("Access-Control-Allow-Headers",
                               "Authorization, Content-Type, If-None-Match, Prefer, X-Request-Id");
                res.set_header("Access-Control-Max-Age", "600");
            }
            return httplib::Server::HandlerResponse::Handled;
        }
        return httplib::Server::HandlerResponse::Unhandled;
    });
    m_http.set_post_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
        RequestContext& ctx = current_request();
        ctx.handler_ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - ctx.start)
                .count();
        res.set_header("X-Request-Id", ctx.id);
        apply_cors(m_cors_any, m_cors_origins, req, res);
    });
    // Errors raised before or outside a route (404, 413 from the body limit, 414...) get the
    // same JSON body as ours; bodies a route already wrote are left alone.
    m_http.set_error_handler(
        httplib::Server::HandlerWithResponse([](const httplib::Request&, httplib::Response& res) {
            if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
            api::ApiError e{"http_error", "HTTP error " + std::to_string(res.status)};
            if (res.status == 400) e = {"bad_request", "malformed HTTP request"};
            if (res.status == 404) e = {"not_found", "no such endpoint"};
            if (res.status == 413)
                e = {"payload_too_large", "request body is over the upload limit"};
            if (res.status == 414) e = {"uri_too_long", "request URI is too long"};
            // Any other status keeps cpp-httplib's number under the code http_error.
            send_error(res, e, e.code == "http_error" ? res.status : 0);
            return httplib::Server::HandlerResponse::Handled;
        }));
    m_http.set_exception_handler([](const httplib::Request& req, httplib::Response& res,
                                    const std::exception_ptr& ep) {
        std::string what = "unknown exception";
        try {
            std::rethrow_exception(ep);
        } catch (const std::exception& e) {
            what = e.what();
        } catch (...) {
        }
        spdlog::error("{} {} {}: unhandled exception: {}", current_request().id,
                      api::printable(req.method, 16), api::printable(req.path, 256),
                      api::printable(what, 512));
        send_error(res, {"internal", "internal error (request id " + current_request().id + ")"});
    });
    m_http.set_logger([this](const httplib::Request& req, const httplib::Response& res) {
        RequestContext& ctx = current_request();
        const double seconds =
            ctx.active ? std::chrono::duration<double>(std::chrono::steady_clock::now() - ctx.start)
                             .count()
                       : 0.0;
        m_metrics.request(ctx.route, req.method, res.status, seconds);
        if (m_config.access_log)
            spdlog::info("{} {} {} {} {}B {:.2f}ms (handler {:.2f}ms)", ctx.id,
                         api::printable(req.method, 16), api::printable(req.path, 256), res.status,
                         res.get_header_value("Content-Length"), seconds * 1000.0, ctx.handler_ms);
        ctx.active = false;
    });
}

void Service::install_ops_routes() {
    m_http.Get("/healthz", [](const httplib::Request&, httplib::Response& res) {
        set_route("/healthz");
        send_json(res, 200, {{"status", "ok"}, {"build", build_id()}}, "no-store");
    });
    m_http.Get("/readyz", [this](const httplib::Request&, httplib::Response& res) {
        set_route("/readyz");
        const bool writable = m_store->writable();
        const bool ready = !m_stopping && writable && m_renderer != nullptr;
        // A replica whose shared store is down still serves the textons it holds, so it stays
        // in the load balancer (were it to leave, every replica would leave at once) and says
        // it is degraded; uploads answer 503 meanwhile.
        nlohmann::json shared = nullptr;
        bool degraded = false;
        if (store::RedisStore* r = m_store->shared()) {
            auto ping = r->ping();
            degraded = !ping;
            shared = {{"url", r->describe()}, {"up", ping.ok()}};
            if (!ping) shared["error"] = ping.error().message;
        }
        nlohmann::json calibration = nlohmann::json::array();
        for (const auto& c : m_renderer->calibration())
            calibration.push_back(
                {{"backend", c.backend}, {"tiles16_ms", c.tile_ms}, {"hd_frame_ms", c.frame_ms}});
        send_json(res, ready ? 200 : 503,
                  {{"ready", ready},
                   {"degraded", degraded},
                   {"shared_store", shared},
                   {"stopping", m_stopping.load()},
                   {"backend",
                    {{"name", m_renderer->frames_backend()},
                     {"tiles", m_renderer->tiles_backend()},
                     {"renderer", m_renderer->renderer()},
                     {"reason", m_renderer->reason()},
                     {"calibration", calibration}}},
                   {"store",
                    {{"writable", writable},
                     {"textons", m_store->count()},
                     {"quarantined", m_store->quarantined()},
                     {"mixes_quarantined", m_mixes->quarantined()}}}},
                  "no-store");
    });
    m_http.Get("/metrics", [this](const httplib::Request&, httplib::Response& res) {
        set_route("/metrics");
        res.set_header("Cache-Control", "no-store");
        res.set_content(m_metrics.prometheus_text(), "text/plain; version=0.0.4; charset=utf-8");
    });
    m_http.Get("/v1/openapi.yaml", [](const httplib::Request&, httplib::Response& res) {
        set_route("/v1/openapi.yaml");
        res.set_header("Cache-Control", "public, max-age=300");
        res.set_content(api::kOpenApiYaml, "application/yaml");
    });
}

// The page of server/web/, read into memory once: no stat() per request on the hot path, and
// a request can only name a file that is in the map, never a path.
void Service::install_web_routes() {
    namespace fs = std::filesystem;
    const std::string dir = m_config.web_dir.empty() ? TEXTOND_WEB_DIR : m_config.web_dir;
    const std::map<std::string, std::string> types = {{".html", "text/html; charset=utf-8"},
                                                      {".js", "text/javascript; charset=utf-8"},
                                                      {".css", "text/css; charset=utf-8"},
                                                      {".png", "image/png"},
                                                      {".svg", "image/svg+xml"},
                                                      {".json", "application/json"}};
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::end(it);
         it.increment(ec)) {
        if (!it->is_regular_file() || m_web.size() >= 256) continue;
        auto type = types.find(it->path().extension().string());
        if (type == types.end()) continue;
        auto body = io::read_file(it->path().string());
        if (!body) continue;
        const std::string rel = fs::relative(it->path(), dir, ec).generic_string();
        m_web["/static/" + rel] = {std::move(body.value()), type->second};
    }
    if (!m_web.count("/static/index.html"))
        spdlog::warn("web: no page in {} (the API works; / answers 404)", dir);
    else
        spdlog::info("web: {} files from {}", m_web.size(), dir);
    auto serve = [this](const std::string& key, httplib::Response& res) {
        auto f = m_web.find(key);
        if (f == m_web.end()) return send_error(res, {"not_found", "no such file"});
        // The page changes with the build; revalidate rather than cache for a year.
        res.set_header("Cache-Control", "no-cache");
        res.set_content(f->second.body, f->second.content_type.c_str());
    };
    m_http.Get("/", [serve](const httplib::Request&, httplib::Response& res) {
        set_route("/");
        serve("/static/index.html", res);
    });
    m_http.Get(R"(/static/(.+))", [serve](const httplib::Request& req, httplib::Response& res) {
        set_route("/static/{file}");
        serve("/static/" + req.matches[1].str(), res);
    });
    // Installed last: every other POST, as a content-reader route so that cpp-httplib never
    // reads into memory a body that no route asked for.
    m_http.Post(R"(.*)",
                [](const httplib::Request&, httplib::Response& res, const httplib::ContentReader&) {
                    set_route("unmatched");
                    send_error(res, {"not_found", "no such endpoint"});
                });
}

void Service::send_pool_full(httplib::Response& res) {
    const int wait_s = 1 + m_pool->queued() / std::max(1, m_pool->workers());
    res.set_header("Retry-After", std::to_string(wait_s));
    send_error(res,
               {"overloaded", "every analysis worker is busy and the queue is full; retry after " +
                                  std::to_string(wait_s) + " s"});
}

Result<int> Service::bind() {
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

void Service::run() {
    m_http.listen_after_bind();
}

void Service::stop() {
    if (m_stopping.exchange(true)) return;
    m_http.stop();
}

} // namespace textond::http
