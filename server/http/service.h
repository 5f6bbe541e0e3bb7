#pragma once
// The HTTP service of `textond serve`: routes of api/openapi.yaml on cpp-httplib, wired to the
// texton store, the analysis pool, the render backends and the image cache.
#include "core/result.h"
#include "render/backend.h"
#include "render/cancel.h"
#include "render/renderer.h"
#include "server/http/admission.h"
#include "server/http/analysis_pool.h"
#include "server/http/config.h"
#include "server/http/connection.h"
#include "server/http/gate.h"
#include "server/http/image_cache.h"
#include "server/http/metrics.h"
#include "server/http/mix_service.h"
#include "server/http/mix_store.h"
#include "server/http/texton_service.h"
#include "server/http/texton_store.h"

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

class Service {
public:
    static Result<std::unique_ptr<Service>> create(ServeConfig config);
    ~Service();

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
    explicit Service(ServeConfig config);
    void install_hooks();
    void install_ops_routes();
    void install_web_routes();
    void install_texton_routes();
    void install_image_routes();
    void install_mix_routes();
    void install_surface_routes();

    // surface_routes.cpp
    void surface_points(const httplib::Request& req, const std::string& id, httplib::Response& res,
                        const httplib::ContentReader& reader);
    void surface_mesh(const httplib::Request& req, const std::string& id, httplib::Response& res,
                      const httplib::ContentReader& reader);

    // mix_routes.cpp
    void create_mix(const httplib::Request& req, httplib::Response& res,
                    const httplib::ContentReader& reader);
    void get_mix(const std::string& id, httplib::Response& res);

    // texton_routes.cpp
    void upload(const httplib::Request& req, httplib::Response& res,
                const httplib::ContentReader& reader);
    void get_texton(const std::string& id, httplib::Response& res);
    void texton_status(const std::string& id, httplib::Response& res);
    void texton_file(const std::string& id, const std::string& ext, httplib::Response& res);
    void texton_kit(const httplib::Request& req, const std::string& id, httplib::Response& res);
    void delete_texton(const httplib::Request& req, const std::string& id, httplib::Response& res);
    void list_textons(const httplib::Request& req, httplib::Response& res);
    nlohmann::json texton_json(const api::TextonMeta& meta) const;
    void send_refused(httplib::Response& res, const TextonService::Refused& r);
    void send_ingested(const httplib::Request& req, httplib::Response& res,
                       const TextonService::Ingested& in);
    bool authorised(const httplib::Request& req, httplib::Response& res) const;

    // image_routes.cpp
    struct ImageJob;
    // Answers from the image cache (ETag, 304) or from `produce`, encoded and cached under `key`.
    void serve_cached(const httplib::Request& req, httplib::Response& res, const std::string& id,
                      const std::string& key, api::ImageFormat format,
                      const std::function<Result<core::Image>(const render::Cancel&)>& produce,
                      bool mix, std::int64_t pixels, double mni);
    Result<core::Image> render_noise(const std::string& id, const render::NoiseRequest& q,
                                     bool whole_machine, const char* kind);
    Result<core::Image> render_mix(const std::string& id, const render::NoiseRequest& q,
                                   bool whole_machine, const char* kind);
    void serve_image(const httplib::Request& req, httplib::Response& res, const ImageJob& job);
    void spectrum(const httplib::Request& req, const std::string& id, httplib::Response& res);
    void exemplar(const std::string& id, httplib::Response& res);
    void tilejson(const httplib::Request& req, const std::string& id, httplib::Response& res,
                  bool mix = false);
    std::string etag_for(const std::string& key) const;
    // 429 with a Retry-After from the analysis pool's queue (uploads and mixes).
    void send_pool_full(httplib::Response& res);
    std::string base_url(const httplib::Request& req) const;

    ServeConfig m_config;
    HttpServer m_http;
    Metrics m_metrics;
    std::unique_ptr<TextonStore> m_store;
    std::unique_ptr<AnalysisPool> m_pool;
    std::unique_ptr<MixStore> m_mixes;
    std::unique_ptr<TextonService> m_textons;  // the ingest workflow behind POST /v1/textons
    std::unique_ptr<MixService> m_mix_service; // the workflow behind POST /v1/mixes
    ImageCache m_cache;
    std::unique_ptr<render::Renderer> m_renderer; // every evaluation goes through it
    struct StaticFile {
        std::string body;
        std::string content_type;
    };
    std::map<std::string, StaticFile> m_web; // "/static/app.js" -> bytes, read once at start
    Gate m_gate;                             // slots, budgets and the answers when they are full
    const bool m_cors_any;                   // --cors-origin "*"
    const std::vector<std::string> m_cors_origins; // else the listed origins, parsed once
    std::atomic<bool> m_stopping{false};
    int m_port = 0;
};

// Identifies the build in ETags and /healthz: version, commit, noise and analysis versions.
const std::string& build_id();

} // namespace textond::http
