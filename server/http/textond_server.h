#pragma once
// The server of `textond serve` and the place its parts are built: owns the stores, the analysis
// pool, the renderer, the image cache, the Gate and the application services (app/), and wires the
// routes of api/openapi.yaml (one table, routes.cpp) to the route groups (texton_routes.h,
// image_routes.h, mix_routes.h, surface_routes.h) on connection.h's HttpServer (cpp-httplib).
#include "core/result.h"
#include "render/backend.h"
#include "render/cancel.h"
#include "render/renderer.h"
#include "server/app/analysis_pool.h"
#include "server/app/image_service.h"
#include "server/app/image_source.h"
#include "server/app/metrics.h"
#include "server/app/mix_service.h"
#include "server/app/mix_source.h"
#include "server/app/splat_source.h"
#include "server/app/texton_service.h"
#include "server/app/texton_source.h"
#include "server/http/config.h"
#include "server/http/connection.h"
#include "server/http/gate.h"
#include "server/http/image_routes.h"
#include "server/http/imports.h"
#include "server/http/mix_routes.h"
#include "server/http/ops_routes.h"
#include "server/http/request_body.h"
#include "server/http/sign_routes.h"
#include "server/http/splat_routes.h"
#include "server/http/surface_routes.h"
#include "server/http/texton_routes.h"
#include "server/store/image_cache.h"
#include "server/store/mix_store.h"
#include "server/store/texton_store.h"

#include <httplib.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace textond::http {

class TextondServer {
public:
    static Result<std::unique_ptr<TextondServer>> create(ServeConfig config);
    ~TextondServer();

    // Binds the listening socket (port 0: any free port) and returns the port.
    Result<int> bind();
    // Serves until stop(); returns when in-flight requests have finished.
    void run();
    // Stops accepting, lets in-flight requests finish; safe from any thread.
    void stop();

    int port() const { return m_port; }
    const ServeConfig& config() const { return m_config; }
    Metrics& metrics() { return m_metrics; }
    const std::string& backend_description() const { return m_renderer->reason(); }

private:
    explicit TextondServer(ServeConfig config);
    std::optional<Error> open_parts(); // stores, renderer, pool, services
    void make_services();
    void add_gauges();
    void install_hooks();
    // The checks before any route: framing, the upload limit by Content-Length, CORS preflight.
    httplib::Server::HandlerResponse pre_route(const httplib::Request& req, httplib::Response& res);
    // routes.cpp: the route table, in the order cpp-httplib tries it.
    void install_routes();
    void install_get_routes();

    ServeConfig m_config;
    HttpServer m_http;
    Metrics m_metrics;
    std::unique_ptr<TextonStore> m_store;
    std::unique_ptr<AnalysisPool> m_pool;
    std::unique_ptr<MixStore> m_mixes;
    std::unique_ptr<SplatStore> m_splats;
    std::unique_ptr<TextonService> m_textons;      // the ingest workflow behind POST /v1/textons
    std::unique_ptr<MixService> m_mix_service;     // the workflow behind POST /v1/mixes
    std::unique_ptr<SplatService> m_splat_service; // and behind POST /v1/splats
    ImageCache m_cache;
    std::unique_ptr<render::Renderer> m_renderer; // every evaluation goes through it
    // What an image's id names, each kind once: their image routes are installed in this order.
    std::vector<std::unique_ptr<ImageSource>> m_sources;
    TextonSource* m_texton_source = nullptr; // the first; a texton's own routes use it
    std::unique_ptr<ImageService> m_images;
    std::unique_ptr<SurfaceService> m_surfaces;
    std::unique_ptr<ImageRoutes> m_image_routes;
    std::unique_ptr<TextonRoutes> m_texton_routes;
    std::unique_ptr<MixRoutes> m_mix_routes;
    std::unique_ptr<SplatRoutes> m_splat_routes;
    std::unique_ptr<SurfaceRoutes> m_surface_routes;
    std::unique_ptr<SignRoutes> m_sign_routes;
    std::unique_ptr<OpsRoutes> m_ops_routes;
    Gate m_gate;           // slots, budgets and the answers when they are full
    const bool m_cors_any; // --cors-origin "*"
    const std::vector<std::string> m_cors_origins; // else the listed origins, parsed once
    std::atomic<bool> m_stopping{false};
    int m_port = 0;
};

} // namespace textond::http
