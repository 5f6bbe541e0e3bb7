#include "server/http/ops_routes.h"

#include "api/openapi_spec.h"
#include "server/app/build_id.h"
#include "server/http/request_context.h"
#include "server/http/responses.h"
#include "server/http/textond_server.h"
#include "server/io/atomic_file.h"
#include "server/io/image_io.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <string_view>

#ifndef TEXTOND_WEB_DIR
#define TEXTOND_WEB_DIR "web"
#endif

namespace textond::http {

OpsRoutes::OpsRoutes(const ServeConfig& config, Metrics& metrics, TextonStore& store,
                     MixStore& mixes, SplatStore& splats, const render::Renderer& renderer,
                     const std::atomic<bool>& stopping)
    : m_metrics(metrics), m_store(store), m_mixes(mixes), m_splats(splats), m_renderer(renderer),
      m_stopping(stopping) {
    namespace fs = std::filesystem;
    const std::string dir = config.web_dir.empty() ? TEXTOND_WEB_DIR : config.web_dir;
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
}

void OpsRoutes::healthz(Req, Res res) {
    set_route("/healthz");
    send_json(res, 200, {{"status", "ok"}, {"build", build_id()}}, "no-store");
}

void OpsRoutes::readyz(Req, Res res) {
    set_route("/readyz");
    const bool writable = m_store.local().writable();
    const auto free = m_store.local().free_bytes();
    const auto no_space = io::recent_no_space(std::chrono::minutes(1));
    const bool ready = !m_stopping && writable;
    // A replica whose shared store is down still serves the textons it holds, so it stays in
    // the load balancer (were it to leave, every replica would leave at once) and says it is
    // degraded; uploads answer 503 meanwhile.
    nlohmann::json shared = nullptr;
    bool degraded = false;
    if (store::RedisStore* r = m_store.shared()) {
        const auto health = r->health();
        degraded = health.problem.has_value();
        shared = {{"url", r->describe()}, {"up", health.up}};
        if (health.problem) shared["error"] = *health.problem;
    }
    nlohmann::json calibration = nlohmann::json::array();
    for (const auto& c : m_renderer.calibration())
        calibration.push_back(
            {{"backend", c.backend}, {"tiles16_ms", c.tile_ms}, {"hd_frame_ms", c.frame_ms}});
    send_json(res, ready ? 200 : 503,
              {{"ready", ready},
               {"degraded", degraded},
               {"shared_store", shared},
               {"stopping", m_stopping.load()},
               {"backend",
                {{"name", m_renderer.frames_backend()},
                 {"tiles", m_renderer.tiles_backend()},
                 {"renderer", m_renderer.renderer()},
                 {"reason", m_renderer.reason()},
                 {"calibration", calibration}}},
               {"store",
                {{"writable", writable},
                 {"free_bytes", free ? nlohmann::json(*free) : nlohmann::json(nullptr)},
                 // A file write refused for lack of space in the last minute: the probe above
                 // writes two bytes, which a disk too full for a texton still holds.
                 {"no_space", no_space ? nlohmann::json(*no_space) : nlohmann::json(nullptr)},
                 {"textons", m_store.local().count()},
                 // The first store::QuarantineList::kListed names of each, by name.
                 {"quarantined", m_store.local().quarantined()},
                 {"mixes_quarantined", m_mixes.quarantined()},
                 {"splats_quarantined", m_splats.quarantined()}}}},
              "no-store");
}

void OpsRoutes::metrics(Req, Res res) {
    set_route("/metrics");
    res.set_header("Cache-Control", "no-store");
    std::string text = m_metrics.prometheus_text();
    fit_ranges(res, text.size());
    res.set_content(text, "text/plain; version=0.0.4; charset=utf-8");
}

void OpsRoutes::openapi(Req, Res res) {
    set_route("/v1/openapi.yaml");
    res.set_header("Cache-Control", "public, max-age=300");
    fit_ranges(res, std::string_view(api::kOpenApiYaml).size());
    res.set_content(api::kOpenApiYaml, "application/yaml");
}

void OpsRoutes::page(Req, Res res) {
    set_route("/");
    serve_web("/static/index.html", res);
}

void OpsRoutes::static_file(Req req, Res res) {
    set_route("/static/{file}");
    serve_web("/static/" + req.matches[1].str(), res);
}

void OpsRoutes::serve_web(const std::string& key, Res res) const {
    auto f = m_web.find(key);
    if (f == m_web.end()) return send_error(res, {"not_found", "no such file"});
    // The page changes with the build; revalidate rather than cache for a year.
    res.set_header("Cache-Control", "no-cache");
    fit_ranges(res, f->second.body.size());
    res.set_content(f->second.body, f->second.content_type.c_str());
}

} // namespace textond::http
