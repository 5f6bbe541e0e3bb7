// The image routes: the cached answer (ETag, 304, the transfer budget) around ImageService's
// work, admitted through the Gate.
#include "server/http/image_routes.h"

#include "api/noise_fields.h"
#include "render/prepared_texton.h"
#include "server/app/engine_kit.h"
#include "server/app/work_cost.h"
#include "server/http/request_context.h"
#include "server/http/responses.h"
#include "server/io/slow_point.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>

namespace textond::http {

namespace {

// One engine kit's CPU a channel (its threshold tables and reference values; r does not matter):
// fitted on half the shared exemplars, within 7% on the other half (tests/bench/kit_cost.py).
constexpr double kKitWorkSPerChannel = 0.18;

// Writes the cached bytes straight to the socket: no copy into the response (a warm tile is
// ~200 kB, and copying it was a fifth of a cache hit's CPU time).
void send_cached(httplib::Response& res, Metrics& metrics, std::shared_ptr<const CachedImage> image,
                 std::shared_ptr<BudgetLease> lease = {}) {
    const std::size_t size = image->body.size();
    fit_ranges(res, size);
    const std::string type = image->content_type;
    // The lease (bytes of the transfer budget) goes when cpp-httplib drops the provider, after
    // the last byte was written.
    res.set_content_provider(
        size, type.c_str(),
        [image = std::move(image), lease = std::move(lease), &metrics,
         t0 = std::chrono::steady_clock::now()](std::size_t offset, std::size_t length,
                                                httplib::DataSink& sink) {
            if (offset > image->body.size()) return false;
            const bool ok = sink.write(image->body.data() + offset,
                                       std::min(length, image->body.size() - offset));
            if (ok && offset + length == image->body.size())
                metrics.stage(
                    "send",
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
            return ok;
        });
}

// Compressed formats never exceed the raw bytes of 8-bit RGBA (plus headers).
std::size_t encoded_bytes_at_most(api::ImageFormat f, std::int64_t pixels) {
    const std::size_t per = f == api::ImageFormat::exr ? 16 : f == api::ImageFormat::png16 ? 8 : 4;
    return static_cast<std::size_t>(pixels) * per + 4096;
}

} // namespace

ImageRoutes::ImageRoutes(const ServeConfig& config, ImageService& images, TextonSource& textons,
                         ImageCache& cache, Gate& gate, Metrics& metrics, const int& port)
    : m_config(config), m_images(images), m_textons(textons), m_cache(cache), m_gate(gate),
      m_metrics(metrics), m_links(config, metrics, port) {}

const char* ImageRoutes::route_name(const ImageSource& source, const std::string& route) {
    return m_route_names.emplace_back("/v1/" + std::string(source.collection()) + "/" + route)
        .c_str();
}

void ImageRoutes::serve_cached(const httplib::Request& req, httplib::Response& res,
                               const std::string& id, const std::string& key,
                               api::ImageFormat format, const Produce& produce, std::int64_t pixels,
                               double work_s, int quality, double cpu_share) {
    auto cached = m_cache.get(key);
    m_metrics.tile_cache(cached != nullptr);
    const std::string etag = cached ? cached->etag : m_images.etag(key);
    // A signed URL with exp must not outlive it in any cache (the edge's, a CDN's, a browser's).
    const std::string cache_control = m_links.cache_control_for(req);
    auto validators = [&] {
        res.set_header("ETag", etag);
        res.set_header("Cache-Control", cache_control);
    };
    // If-Match first (RFC 9110 13.2.2); a client that holds one rendering's tag and not this
    // one's (another build, another backend) is told so rather than sent other bytes.
    if (!if_match_holds(req.get_header_value("If-Match"), etag))
        return send_error(
            res, {"precondition_failed",
                  "If-Match names no entity tag of this image (its ETag is " + etag + ")"});
    if (etag_matches(req.get_header_value("If-None-Match"), etag)) {
        validators();
        res.status = 304;
        return;
    }
    if (cached) {
        validators();
        return send_cached(res, m_metrics, std::move(cached));
    }
    // Only renders count against a client's rate: hits and 304s cost next to nothing.
    if (!m_links.within_rate(req, res)) return;
    // The encoded image outlives the slot while a client reads it: large ones hold bytes of the
    // transfer budget until they are written (10 concurrent 4K regions took 326 MB without).
    std::shared_ptr<BudgetLease> lease;
    if (const std::size_t out = encoded_bytes_at_most(format, pixels);
        out > (std::size_t{1} << 20)) {
        lease = m_gate.lease_transfer(res, out);
        if (!lease) return;
    }
    auto entry = produce_in_slot(res, id, format, quality, produce, work_s, cpu_share);
    if (!entry) return;
    entry->etag = etag;
    m_cache.put(key, entry);
    validators(); // on the image only: an error carries no ETag and is never immutable
    send_cached(res, m_metrics, std::move(entry), std::move(lease));
}

// Render, resample and encode in one slot: the float image and its encoding (230 MB for the
// largest region) exist only while a slot is held.
std::shared_ptr<CachedImage>
ImageRoutes::produce_in_slot(httplib::Response& res, const std::string& id, api::ImageFormat format,
                             int quality, const Produce& produce, double work_s, double cpu_share) {
    using Clock = std::chrono::steady_clock;
    auto seconds = [](Clock::time_point a, Clock::time_point b) {
        return std::chrono::duration<double>(b - a).count();
    };
    const auto t0 = Clock::now();
    auto slot = m_gate.admit(res, work_s, cpu_share);
    if (!slot) return nullptr;
    const auto t1 = Clock::now();
    m_metrics.stage("queue", seconds(t0, t1));
    const render::Cancel cancel = m_gate.work_cancel();
    if (!io::slow_point("render", work_s, [&] { return cancel.stop(); })) {
        m_gate.send_work_error(res, render::abandoned(&cancel, "the render"), cancel);
        return nullptr;
    }
    auto image = produce(cancel);
    if (!image) {
        m_gate.send_work_error(res, image.error(), cancel);
        return nullptr;
    }
    const auto t2 = Clock::now();
    m_metrics.stage("render", seconds(t1, t2));
    // A client gone during the render gets no encode: a large WebP or AVIF had run for seconds
    // after a client that hung up. A WebP encode also stops as it goes. A passed deadline does
    // not stop it: the render is done, and its image is served and cached.
    auto gone = [&] { return cancel.stop() && !cancel.deadline_passed(); };
    if (gone()) {
        m_gate.send_work_error(res, render::abandoned(&cancel, "the encode"), cancel);
        return nullptr;
    }
    auto bytes = m_images.encode(std::move(image.value()), format, quality, id, gone);
    m_metrics.stage("encode", seconds(t2, Clock::now()));
    if (!bytes) {
        m_gate.send_work_error(res, bytes.error(), cancel);
        return nullptr;
    }
    auto entry = std::make_shared<CachedImage>();
    entry->body = std::move(bytes.value());
    entry->content_type = api::content_type(format);
    entry->texton_id = id;
    return entry;
}

void ImageRoutes::serve(const httplib::Request& req, httplib::Response& res,
                        const ImageService::Job& job) {
    // Admission's estimate: a window's pixels times the renders it takes, and the points its
    // textons list at an exact zoomed-out level. Also the id's existence check.
    const auto cost = job.source->cost(job.id, job.noise.map);
    if (!cost) return send_error(res, to_api_error(cost.error()));
    const ImageSource::WindowCost& c = cost.value();
    const render::NoiseRequest& q = job.request;
    const double work_s =
        noise_work_s(job.pixels() * c.passes, q.mni, c.order) +
        zoomed_points_work_s(q.width, q.height, q.level, q.mni, c.size) * c.textons;
    serve_cached(
        req, res, job.id, ImageService::key(job), job.format,
        [&](const render::Cancel& cancel) { return m_images.render(job, cancel); }, job.pixels(),
        work_s, job.quality, c.cpu_share);
}

ImageRoutes::Handler ImageRoutes::tile(ImageSource& source, const std::string& route_template,
                                       TileParser parse) {
    const char* route = route_name(source, route_template);
    return [this, route, parse, &source](const httplib::Request& req, httplib::Response& res) {
        set_route(route);
        api::TileRequest t;
        // No extension: the format the client's Accept header asks for (AVIF, WebP, else PNG);
        // caches must key the answer on Accept too.
        std::string ext = req.matches.size() > 5 ? req.matches[5].str() : "";
        const auto params = m_links.served_query(req, res, ext);
        if (!params) return;
        if (ext.empty()) { // a preset's format, else the one Accept asks for
            if (const auto p = req.params.find("preset");
                p != req.params.end() && !m_config.presets.empty())
                ext = m_config.presets.at(p->second).format;
            if (ext.empty() && params->count("encoding")) ext = "png"; // elevation: RGB bytes
            if (ext.empty())
                ext = api::extension(api::negotiate_format(req.get_header_value("Accept")));
            res.set_header("Vary", "Accept");
        }
        if (auto e = parse(req.matches[1].str(), req.matches[2].str(), req.matches[3].str(),
                           req.matches[4].str(), ext, *params, t, source.has_maps()))
            return send_error(res, *e);
        ImageService::Job job{
            t.id,     "tile",
            t.format, to_noise_request(t.level, t.x0(), t.y0(), t.size, t.size, t.noise),
            t.size,   t.size,
            false,    &source,
            t.noise,  t.quality};
        serve(req, res, job);
    };
}

ImageRoutes::Handler ImageRoutes::region(ImageSource& source, const std::string& route_template) {
    const char* route = route_name(source, route_template);
    return [this, route, &source](const httplib::Request& req, httplib::Response& res) {
        set_route(route);
        api::RegionRequest r;
        const auto params = m_links.served_query(req, res, req.matches[2].str());
        if (!params) return;
        if (auto e = api::parse_region(req.matches[1].str(), req.matches[2].str(), *params,
                                       m_config.limits, r, source.has_maps()))
            return send_error(res, *e);
        ImageService::Job job{
            r.id,     "region",
            r.format, to_noise_request(r.level, r.x, r.y, r.width, r.height, r.noise),
            r.width,  r.height,
            true,     &source,
            r.noise,  r.quality};
        serve(req, res, job);
    };
}

void ImageRoutes::tileable(const httplib::Request& req, httplib::Response& res) {
    set_route("/v1/textons/{id}/tileable.{format}");
    api::TileableRequest t;
    const auto params = m_links.served_query(req, res, req.matches[2].str());
    if (!params) return;
    if (auto e = api::parse_tileable(req.matches[1].str(), req.matches[2].str(), *params,
                                     m_config.limits, t))
        return send_error(res, *e);
    auto job = m_images.tileable(t);
    if (!job) return send_error(res, to_api_error(job.error()));
    serve(req, res, job.value());
}

// The exemplar's power spectrum (periodic component, centre crop of at most 512 x 512) next to
// that of a window of its texton noise of the same size.
void ImageRoutes::spectrum(const httplib::Request& req, httplib::Response& res) {
    set_route("/v1/textons/{id}/spectrum.png");
    const std::string id = req.matches[1].str();
    api::NoiseParams noise;
    const auto params = m_links.served_query(req, res, "png");
    if (!params) return;
    if (auto e = api::parse_spectrum(id, *params, noise)) return send_error(res, *e);
    auto order = m_textons.interpolation_order(id);
    if (!order) return send_error(res, to_api_error(order.error()));
    constexpr std::int64_t kPixels = 512 * 512;
    serve_cached(
        req, res, id, m_textons.spectrum_key(id, noise), api::ImageFormat::png,
        [&](const render::Cancel& cancel) { return m_textons.spectrum(id, noise, cancel); },
        kPixels, noise_work_s(kPixels, noise.mni, order.value()));
}

// The texton's quality report as JSON (quality_report.h), computed in a render slot (two windows
// of at most 256 x 256) every time; its PNG is the texton's `report`, cached.
void ImageRoutes::quality(const httplib::Request& req, httplib::Response& res) {
    set_route("/v1/textons/{id}/quality.json");
    const std::string id = req.matches[1].str();
    api::NoiseParams noise;
    const auto params = m_links.served_query(req, res, "");
    if (!params) return;
    if (auto e = api::parse_spectrum(id, *params, noise)) return send_error(res, *e);
    auto order = m_textons.interpolation_order(id);
    if (!order) return send_error(res, to_api_error(order.error()));
    auto pixels = m_textons.report_work_pixels(id);
    if (!pixels) return send_error(res, to_api_error(pixels.error()));
    if (!m_links.within_rate(req, res)) return; // a render every time
    auto slot = m_gate.admit(res, noise_work_s(pixels.value(), noise.mni, order.value()));
    if (!slot) return;
    const render::Cancel cancel = m_gate.work_cancel();
    auto report = m_textons.quality(id, noise, cancel);
    if (!report) return m_gate.send_work_error(res, report.error(), cancel);
    const auto preset = req.params.find("preset");
    report.value().json["links"] = {
        {"png", m_links.signed_link(
                    req, "/v1/" + std::string(m_textons.collection()) + "/" + id + "/quality.png" +
                             (!m_config.presets.empty() && preset != req.params.end()
                                  ? "?preset=" + preset->second
                                  : "?" + api::noise_query(noise, api::kReportRoute)))}};
    send_json(res, 200, report.value().json, "no-cache");
}

ImageRoutes::Handler ImageRoutes::report(ImageSource& source) {
    const char* route = route_name(source, "{id}/quality.png");
    return [this, route, &source](const httplib::Request& req, httplib::Response& res) {
        set_route(route);
        const std::string id = req.matches[1].str();
        api::NoiseParams noise;
        const auto params = m_links.served_query(req, res, "png");
        if (!params) return;
        if (auto e = api::parse_spectrum(id, *params, noise)) return send_error(res, *e);
        auto order = source.interpolation_order(id);
        if (!order) return send_error(res, to_api_error(order.error()));
        auto pixels = source.report_work_pixels(id);
        if (!pixels) return send_error(res, to_api_error(pixels.error()));
        serve_cached(
            req, res, id, ImageService::report_key(source, id, noise), api::ImageFormat::png,
            [&](const render::Cancel& cancel) { return source.report(id, noise, cancel); },
            pixels.value(), noise_work_s(pixels.value(), noise.mni, order.value()));
    };
}

void ImageRoutes::exemplar(const httplib::Request& req, httplib::Response& res) {
    set_route("/v1/textons/{id}/exemplar.png");
    const std::string id = req.matches[1].str();
    if (auto e = api::check_texton_id(id)) return send_error(res, *e);
    if (!takes_no_query(req, res)) return;
    auto png = m_textons.store().verified_exemplar_png(id);
    if (!png) return send_error(res, to_api_error(png.error()));
    res.set_header("Cache-Control", kDeletableFor);
    fit_ranges(res, png.value().size());
    res.set_content(png.value(), "image/png");
}

void ImageRoutes::kit(const httplib::Request& req, httplib::Response& res) {
    set_route("/v1/textons/{id}/kit.tar");
    const std::string id = req.matches[1].str();
    if (auto e = api::check_texton_id(id)) return send_error(res, *e);
    auto served = m_links.served_query(req, res, "");
    if (!served) return;
    api::Query q;
    // A preset's fields are an image's; of them the kit takes its density.
    if (const auto mni = served->find("mni"); mni != served->end()) q.emplace(*mni);
    if (m_config.presets.empty()) q = *served;
    api::NoiseParams p;
    if (auto e = api::parse_kit(id, q, p)) return send_error(res, *e);
    const std::string key = "kit/" + id + "/" + api::exact_text(p.mni);
    // Stored still, before the cache answers: a DELETE on another replica erases no entry here.
    if (auto order = m_textons.interpolation_order(id); !order)
        return send_error(res, to_api_error(order.error()));
    auto cached = m_cache.get(key);
    m_metrics.tile_cache(cached != nullptr);
    // The same kit is the same bytes (for a build): a client revalidates it for a 304, as an
    // image, where it had fetched the whole tar each time.
    const std::string etag = cached ? cached->etag : m_images.etag(key);
    const auto headers = [&] {
        // It holds texton.exr: revalidated, never served from a cache after a DELETE.
        res.set_header("Cache-Control", kDeletableFor);
        res.set_header("ETag", etag);
        res.set_header("Content-Disposition",
                       "attachment; filename=\"" + engine_kit_directory(id) + ".tar\"");
    };
    if (etag_matches(req.get_header_value("If-None-Match"), etag)) {
        headers();
        res.status = 304;
        return;
    }
    if (cached) {
        headers();
        return send_cached(res, m_metrics, std::move(cached));
    }
    if (!m_links.within_rate(req, res)) return;
    auto record = m_textons.store().record(id);
    if (!record) return send_error(res, to_api_error(record.error()));
    auto exr = m_textons.store().file_bytes(id);
    if (!exr) return send_error(res, to_api_error(exr.error()));
    auto slot = m_gate.admit(res, kKitWorkSPerChannel * record.value().texton.channels,
                             1.0); // all on the CPU
    if (!slot) return;
    auto tar = engine_kit_tar(record.value(), exr.value(), p.mni, "");
    if (!tar) return send_error(res, to_api_error(tar.error()));
    auto entry = std::make_shared<CachedImage>();
    entry->body = std::move(tar.value());
    entry->content_type = "application/x-tar";
    entry->texton_id = id;
    entry->etag = etag;
    m_cache.put(key, entry);
    headers();
    send_cached(res, m_metrics, std::move(entry));
}

// The extension and query of a TileJSON's tile templates. With presets the tiles name the preset
// (and take its format); signed_link signs them when URLs are signed, so one TileJSON opens its
// whole pyramid.
std::pair<std::string, std::string> ImageRoutes::tile_suffix(const httplib::Request& req,
                                                             const api::TileRequest& probe) const {
    if (!m_config.presets.empty()) {
        const std::string& name = req.params.find("preset")->second;
        const std::string& f = m_config.presets.at(name).format;
        return {f.empty() ? "png" : f, "?preset=" + name};
    }
    return {"png", "?" + api::noise_query(probe.noise, api::kTileRoute) +
                       (probe.size != 256 ? "&size=" + std::to_string(probe.size) : "")};
}

ImageRoutes::Handler ImageRoutes::tilejson(ImageSource& source) {
    const char* route = route_name(source, "{id}/tilejson.json");
    return [this, route, &source](const httplib::Request& req, httplib::Response& res) {
        set_route(route);
        tilejson_of(source, req, res);
    };
}

void ImageRoutes::tilejson_of(const ImageSource& source, const httplib::Request& req,
                              httplib::Response& res) {
    const std::string id = req.matches[1].str();
    api::TileRequest probe; // seed, mni and size, checked exactly as the tiles will check them
    const auto params = m_links.served_query(req, res, "");
    if (!params) return;
    // A preset's quality belongs to its format and its tiles, which the templates name by the
    // preset; a TileJSON takes none of its own (its templates are PNG).
    api::Query fields = *params;
    if (!m_config.presets.empty()) fields.erase("quality");
    if (auto e = api::parse_tilejson(id, fields, probe, source.has_maps()))
        return send_error(res, *e);
    if (auto e = source.tilejson_refusal(id, probe.noise)) return send_error(res, to_api_error(*e));
    const std::string prefix = "/v1/" + std::string(source.collection()) + "/";
    const auto [ext, query] = tile_suffix(req, probe);
    const std::string base = m_links.base_url(req);
    const int native_zoom = api::kMapMaxLevel; // level 0: one texel per pixel
    nlohmann::json j = {
        {"tilejson", "3.0.0"},
        {"name", "textond " + id.substr(0, 12)},
        {"description", source.described_as() + id + " (seed " + std::to_string(probe.noise.seed) +
                            ", MNI " + api::query_text(probe.noise.mni) +
                            "), an unbounded seamless plane"},
        {"version", "1.0.0"},
        {"scheme", "xyz"},
        {"tiles",
         {base + m_links.signed_link(req, prefix + id + "/map/{z}/{x}/{y}." + ext + query)}},
        {"minzoom", 0},
        {"maxzoom", api::kMapMaxZoom},
        {"center", {0, 0, native_zoom}},
        {"textond",
         {{"tile_size", probe.size},
          {"marginals", probe.noise.exemplar_marginals ? "exemplar" : "gaussian"},
          {"map", probe.noise.map.name.empty() ? nullptr : nlohmann::json(probe.noise.map.name)},
          {"height_scale",
           probe.noise.map.encoding ? nlohmann::json(probe.noise.map.height_scale) : nullptr},
          {"level_of_zoom", "level = " + std::to_string(api::kMapMaxLevel) +
                                " - z: zoom z shows 2^(24 - z) texels per pixel; z = 24 is "
                                "level 0, one texel per pixel"},
          {"native_zoom", native_zoom},
          {"crs", "Leaflet L.CRS.Simple / OpenLayers pixel projection; y grows downwards"},
          {"game_tiles", base + m_links.signed_link(req, prefix + id + "/tiles/{level}/{x}/{y}." +
                                                             ext + query)}}}};
    // Elevation tiles: what a raster-dem source (MapLibre, Mapbox) reads to decode them.
    if (probe.noise.map.encoding) {
        j["encoding"] = core::elevation_encoding_name(*probe.noise.map.encoding);
        j["tileSize"] = probe.size;
    }
    // The absolute URLs come from the Host header unless --public-url is set.
    if (m_config.public_url.empty()) res.set_header("Vary", "Host");
    send_json(res, 200, j, "no-cache"); // gone with its id, at the edge too
}

} // namespace textond::http
