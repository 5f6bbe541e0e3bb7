#pragma once
// GET routes of images: tiles (game clients, z = level), map tiles and TileJSON (web maps),
// regions (pipelines), tileable textures, the spectrum and the exemplar, of textons, mixes and
// splat maps.
// Every image is a window onto one deterministic function, so its bytes are named by a strong
// ETag and cached; the work is ImageService's, admitted through the Gate.
#include "api/requests.h"
#include "server/app/image_service.h"
#include "server/app/metrics.h"
#include "server/http/config.h"
#include "server/http/gate.h"
#include "server/http/image_links.h"
#include "server/http/imports.h"
#include "server/store/image_cache.h"

#include <httplib.h>

#include <functional>
#include <memory>
#include <string>

namespace textond::http {

class ImageRoutes {
public:
    // `port`: the bound port, for absolute URLs when no --public-url is set.
    ImageRoutes(const ServeConfig& config, ImageService& images, TextonStore& textons,
                MixStore& mixes, ImageCache& cache, Gate& gate, Metrics& metrics, const int& port);

    using Handler = httplib::Server::Handler;
    // Game tiles (z = level) and web-map tiles (z = zoom, level = 24 - z) differ only in parsing:
    // routes.cpp passes api::parse_tile or api::parse_map_tile here (no call in this file names
    // them).
    using TileParser = decltype(&api::parse_tile);
    Handler tile(const char* route, TileParser parse, Source source);
    Handler region(const char* route, Source source);
    void tileable(const httplib::Request& req, httplib::Response& res);
    void spectrum(const httplib::Request& req, httplib::Response& res);
    // The texton's quality report: JSON (png = false) or its PNG.
    void quality(const httplib::Request& req, httplib::Response& res, bool png);
    // A splat's report (ImageService::splat_report), cached like a quality PNG.
    void splat_report(const httplib::Request& req, httplib::Response& res);
    void exemplar(const httplib::Request& req, httplib::Response& res);
    // The engine kit (tar): signed, preset and rate limited like an image, built under a render
    // slot and cached like one.
    void kit(const httplib::Request& req, httplib::Response& res);
    void tilejson(const httplib::Request& req, httplib::Response& res, Source source);

private:
    using Produce = std::function<Result<core::Image>(const render::Cancel&)>;
    void serve(const httplib::Request& req, httplib::Response& res, const ImageService::Job& job);
    // Answers from the image cache (ETag, 304) or from `produce`, encoded and cached under `key`.
    void serve_cached(const httplib::Request& req, httplib::Response& res, const std::string& id,
                      const std::string& key, api::ImageFormat format, const Produce& produce,
                      Source source, std::int64_t pixels, double mni,
                      int quality = api::kDefaultQuality, double cpu_share = 0);
    // The image's bytes, produced and encoded under a render slot; null when the answer (429,
    // 413, 503, an error) was sent instead.
    std::shared_ptr<CachedImage> produce_in_slot(httplib::Response& res, const std::string& id,
                                                 api::ImageFormat format, int quality,
                                                 const Produce& produce, double work_s,
                                                 double cpu_share = 0);
    std::optional<api::ApiError> tilejson_refusal(const std::string& id,
                                                  const api::TileRequest& probe, Source source);
    std::pair<std::string, std::string> tile_suffix(const httplib::Request& req,
                                                    const api::TileRequest& probe) const;
    const ServeConfig& m_config;
    ImageService& m_images;
    TextonStore& m_textons;
    MixStore& m_mixes;
    ImageCache& m_cache;
    Gate& m_gate;
    Metrics& m_metrics;
    ImageLinks m_links;
};

} // namespace textond::http
