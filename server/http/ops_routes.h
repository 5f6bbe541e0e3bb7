#pragma once
// The operator's routes (/healthz, /readyz, /metrics, the OpenAPI document) and the page of
// server/web/, read into memory once: no stat() per request, and a request can only name a file
// that is in the map, never a path.
#include "render/renderer.h"
#include "server/app/metrics.h"
#include "server/http/config.h"
#include "server/http/imports.h"
#include "server/store/mix_store.h"
#include "server/store/splat_store.h"
#include "server/store/texton_store.h"

#include <httplib.h>

#include <atomic>
#include <map>
#include <string>

namespace textond::http {

class OpsRoutes {
public:
    // Reads the page's files from --web-dir (or the installed one).
    OpsRoutes(const ServeConfig& config, Metrics& metrics, TextonStore& store, MixStore& mixes,
              SplatStore& splats, const render::Renderer& renderer,
              const std::atomic<bool>& stopping);

    using Req = const httplib::Request&;
    using Res = httplib::Response&;
    static void healthz(Req req, Res res);
    void readyz(Req req, Res res);
    void metrics(Req req, Res res);
    static void openapi(Req req, Res res);
    void page(Req req, Res res);        // "/": index.html
    void static_file(Req req, Res res); // "/static/{file}"

private:
    void serve_web(const std::string& key, Res res) const;

    struct StaticFile {
        std::string body;
        std::string content_type;
    };
    Metrics& m_metrics;
    TextonStore& m_store;
    MixStore& m_mixes;
    SplatStore& m_splats;
    const render::Renderer& m_renderer;
    const std::atomic<bool>& m_stopping;
    std::map<std::string, StaticFile> m_web; // "/static/app.js" -> bytes, read once at start
};

} // namespace textond::http
