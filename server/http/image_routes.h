#pragma once
// GET routes of images: tiles (game clients, z = level), map tiles and TileJSON (web maps),
// regions (pipelines), tileable textures, the spectrum and the exemplar, of textons, mixes and
// splat maps.
// Every image is a window onto one deterministic function, so its bytes are named by a strong
// ETag and cached; the work is ImageService's, admitted through the Gate.
#include "api/requests.h"
#include "server/app/image_service.h"
#include "server/app/image_source.h"
#include "server/app/metrics.h"
#include "server/app/texton_source.h"
#include "server/http/config.h"
#include "server/http/gate.h"
#include "server/http/image_links.h"
#include "server/http/imports.h"
#include "server/store/image_cache.h"

#include <httplib.h>

#include <deque>
#include <functional>
#include <memory>
#include <string>

namespace textond::http {

class ImageRoutes {
public:
    // `port`: the bound port, for absolute URLs when no --public-url is set.
    // `textons`: the source of the routes only a texton has (tileable, spectrum, quality.json,
    // exemplar, kit).
    ImageRoutes(const ServeConfig& config, ImageService& images, TextonSource& textons,
                ImageCache& cache, Gate& gate, Metrics& metrics, const int& port);

    using Handler = httplib::Server::Handler;
    // Every source's image routes: `route_template` is the one under /v1/{collection}/ that the
    // metrics name it by ("{id}/region.{format}").
    // Game tiles (z = level) and web-map tiles (z = zoom, level = 24 - z) differ only in parsing:
    // routes.cpp passes api::parse_tile or api::parse_map_tile here (no call in this file names
    // them).
    using TileParser = decltype(&api::parse_tile);
    Handler tile(ImageSource& source, const std::string& route_template, TileParser parse);
    Handler region(ImageSource& source, const std::string& route_template);
    Handler tilejson(ImageSource& source);
    // Its report (has_report): a texton's quality PNG, a splat's weights beside its render.
    Handler report(ImageSource& source);

    // A texton's only.
    void tileable(const httplib::Request& req, httplib::Response& res);
    void spectrum(const httplib::Request& req, httplib::Response& res);
    // The texton's quality report as JSON, with a link to its PNG (`report`).
    void quality(const httplib::Request& req, httplib::Response& res);
    void exemplar(const httplib::Request& req, httplib::Response& res);
    // The engine kit (tar): signed, preset and rate limited like an image, built under a render
    // slot and cached like one.
    void kit(const httplib::Request& req, httplib::Response& res);

private:
    using Produce = std::function<Result<core::Image>(const render::Cancel&)>;
    void serve(const httplib::Request& req, httplib::Response& res, const ImageService::Job& job);
    // Answers from the image cache (ETag, 304) or from `produce`, encoded and cached under `key`:
    // a window of `pixels` whose render admission estimates at `work_s` (work_cost.h). The
    // caller has found the id stored (its interpolation order or cost, before the cache).
    void serve_cached(const httplib::Request& req, httplib::Response& res, const std::string& id,
                      const std::string& key, api::ImageFormat format, const Produce& produce,
                      std::int64_t pixels, double work_s, int quality = api::kDefaultQuality,
                      double cpu_share = 0);
    // The image's bytes, produced and encoded under a render slot; null when the answer (429,
    // 413, 503, an error) was sent instead.
    std::shared_ptr<CachedImage> produce_in_slot(httplib::Response& res, const std::string& id,
                                                 api::ImageFormat format, int quality,
                                                 const Produce& produce, double work_s,
                                                 double cpu_share = 0);
    // "/v1/{collection}/" + route, stored in m_route_names.
    const char* route_name(const ImageSource& source, const std::string& route);
    void tilejson_of(const ImageSource& source, const httplib::Request& req,
                     httplib::Response& res);
    std::pair<std::string, std::string> tile_suffix(const httplib::Request& req,
                                                    const api::TileRequest& probe) const;
    const ServeConfig& m_config;
    ImageService& m_images;
    TextonSource& m_textons;
    // The metrics' names of the routes, kept for as long as the requests that point to them.
    std::deque<std::string> m_route_names;
    ImageCache& m_cache;
    Gate& m_gate;
    Metrics& m_metrics;
    ImageLinks m_links;
};

// One source's images (app/image_source.h) under /v1/{collection}/: tiles, map tiles (with and
// without an extension), region, TileJSON, and its report when it has one. The same routes for
// every kind; defined in routes.cpp, the route table, which calls it once per source.
void install_image_routes(httplib::Server& http, ImageRoutes& images, ImageSource& source);

} // namespace textond::http
