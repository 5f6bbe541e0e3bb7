// Images of the noise: tiles (game clients, z = level), map tiles and TileJSON (web maps),
// regions (pipelines) and tileable textures. Every image is a window onto one deterministic
// function, so its bytes are named by a strong ETag and cached.
#include "api/requests.h"
#include "core/grid_poisson.h"
#include "core/periodic_component.h"
#include "core/periodic_resample.h"
#include "core/power_spectrum.h"
#include "render/image_buffers.h"
#include "render/noise_request.h"
#include "server/http/http_support.h"
#include "server/http/service.h"
#include "server/io/image_io.h"
#include "server/io/sha256.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <cstdio>

namespace textond::http {

using Work = render::Renderer::Work;

namespace {

constexpr const char* kImmutable = "public, max-age=31536000, immutable";

io::Encoding encoding_of(api::ImageFormat f) {
    switch (f) {
    case api::ImageFormat::png:
        return io::Encoding::png8;
    case api::ImageFormat::png16:
        return io::Encoding::png16;
    case api::ImageFormat::exr:
        return io::Encoding::exr;
    }
    return io::Encoding::png8;
}

std::string mni_text(double mni) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.17g", mni);
    return buf;
}

// One key per distinct image: everything that changes a pixel or a byte of it.
std::string noise_key(const std::string& id, const render::NoiseRequest& q, api::ImageFormat f,
                      const char* kind, int out_w, int out_h) {
    return std::string(kind) + "/" + id + "/" + std::to_string(q.level) + "/" +
           std::to_string(q.x0) + "/" + std::to_string(q.y0) + "/" + std::to_string(q.width) + "x" +
           std::to_string(q.height) + "/p" + std::to_string(q.period[0]) + "x" +
           std::to_string(q.period[1]) + "/o" + std::to_string(out_w) + "x" +
           std::to_string(out_h) + "/s" + std::to_string(q.seed) + "/m" + mni_text(q.mni) + "." +
           api::extension(f);
}

render::NoiseRequest noise_request(int level, std::int64_t x0, std::int64_t y0, int w, int h,
                                   const api::NoiseParams& noise) {
    render::NoiseRequest q;
    q.level = level;
    q.x0 = x0;
    q.y0 = y0;
    q.width = w;
    q.height = h;
    q.seed = noise.seed;
    q.mni = noise.mni;
    return q;
}

// Writes the cached bytes straight to the socket: no copy into the response (a warm tile is
// ~200 kB, and copying it was a fifth of a cache hit's CPU time).
void send_cached(httplib::Response& res, Metrics& metrics, std::shared_ptr<const CachedImage> image,
                 std::shared_ptr<BudgetLease> lease = {}) {
    const std::size_t size = image->body.size();
    const std::string type = image->content_type;
    // The lease (bytes of the transfer budget) goes when cpp-httplib drops the provider, after
    // the last byte was written.
    res.set_content_provider(
        size, type.c_str(),
        [image = std::move(image), lease = std::move(lease), &metrics,
         t0 = std::chrono::steady_clock::now()](std::size_t offset, std::size_t length,
                                                httplib::DataSink& sink) {
            const bool ok = sink.write(image->body.data() + offset, length);
            if (ok && offset + length == image->body.size())
                metrics.stage(
                    "send",
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
            return ok;
        });
}

std::size_t encoded_bytes_at_most(api::ImageFormat f, std::int64_t pixels) {
    const std::size_t per = f == api::ImageFormat::exr ? 16 : f == api::ImageFormat::png16 ? 8 : 4;
    return static_cast<std::size_t>(pixels) * per + 4096;
}

} // namespace

struct Service::ImageJob {
    std::string id;
    const char* kind; // tile | region | tileable (metrics label)
    api::ImageFormat format;
    render::NoiseRequest request;
    int out_width = 0, out_height = 0; // tileable textures are resampled to the asked size
    bool use_region_backend = false;
    bool mix = false; // id names a texture mix (/v1/mixes/{id}/...)
};

std::string Service::etag_for(const std::string& key) const {
    io::Sha256 h;
    h.update(build_id()).update("\n").update(m_renderer->identity()).update("\n").update(key);
    return "\"" + h.hex().substr(0, 40) + "\"";
}

void Service::serve_cached(const httplib::Request& req, httplib::Response& res,
                           const std::string& id, const std::string& key, api::ImageFormat format,
                           const std::function<Result<core::Image>(const render::Cancel&)>& produce,
                           bool mix, std::int64_t pixels, double mni) {
    int order = 1;
    if (mix) {
        auto found = m_mixes->meta(id);
        if (!found) return send_error(res, to_api_error(found.error()));
        order = found.value().order;
    } else {
        auto found = m_store->find(id);
        if (!found) return send_error(res, to_api_error(found.error()));
        order = found.value().order;
    }
    auto cached = m_cache.get(key);
    m_metrics.tile_cache(cached != nullptr);
    const std::string etag = cached ? cached->etag : etag_for(key);
    res.set_header("ETag", etag);
    res.set_header("Cache-Control", kImmutable);
    if (etag_matches(req.get_header_value("If-None-Match"), etag)) {
        res.status = 304;
        return;
    }
    if (cached) return send_cached(res, m_metrics, std::move(cached));
    // Render, resample and encode in one slot: the float image and its encoding (230 MB for
    // the largest region) exist only while a slot is held.
    // The encoded image outlives the slot while a client reads it: large ones hold bytes of the
    // transfer budget until they are written (10 concurrent 4K regions took 326 MB without).
    std::shared_ptr<BudgetLease> lease;
    if (const std::size_t out = encoded_bytes_at_most(format, pixels);
        out > (std::size_t{1} << 20)) {
        lease = m_gate.lease_transfer(res, out);
        if (!lease) return;
    }
    using Clock = std::chrono::steady_clock;
    auto seconds = [](Clock::time_point a, Clock::time_point b) {
        return std::chrono::duration<double>(b - a).count();
    };
    const auto t0 = Clock::now();
    auto slot = m_gate.admit(res, noise_work_s(pixels, mni, order));
    if (!slot) return;
    const auto t1 = Clock::now();
    m_metrics.stage("queue", seconds(t0, t1));
    const render::Cancel cancel = m_gate.work_cancel();
    auto image = produce(cancel);
    if (!image) return m_gate.send_work_error(res, image.error(), cancel);
    const auto t2 = Clock::now();
    m_metrics.stage("render", seconds(t1, t2));
    auto bytes =
        io::encode_image_memory(image.value(), encoding_of(format),
                                {{"textond:noise", render::kNoiseVersion}, {"textond:texton", id}},
                                m_config.png_compression);
    m_metrics.stage("encode", seconds(t2, Clock::now()));
    render::recycle_image(std::move(image.value())); // the pixels go before the bytes are cached
    if (!bytes) return send_error(res, to_api_error(bytes.error()));
    auto entry = std::make_shared<CachedImage>();
    entry->body = std::move(bytes.value());
    entry->etag = etag;
    entry->content_type = api::content_type(format);
    entry->texton_id = id;
    m_cache.put(key, entry);
    send_cached(res, m_metrics, std::move(entry), std::move(lease));
}

Result<core::Image> Service::render_noise(const std::string& id, const render::NoiseRequest& q,
                                          bool whole_machine, const char* kind) {
    auto prepared = m_store->prepared(id);
    if (!prepared) return prepared.error();
    if (auto err = prepared.value()->check(q)) return *err;
    const auto t0 = std::chrono::steady_clock::now();
    std::string used;
    Result<core::Image> image = m_renderer->noise( // in the caller's slot
        *prepared.value(), q, whole_machine ? Work::frame : Work::tile, &used);
    m_metrics.render(
        used, kind,
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    return image;
}

Result<core::Image> Service::render_mix(const std::string& id, const render::NoiseRequest& q,
                                        bool whole_machine, const char* kind) {
    auto prepared = m_mixes->prepared(id);
    if (!prepared) return prepared.error();
    if (auto err = prepared.value()->check(q)) return *err;
    const auto t0 = std::chrono::steady_clock::now();
    std::string used;
    Result<core::Image> image = m_renderer->mix( // in the caller's slot
        *prepared.value(), q, whole_machine ? Work::frame : Work::tile, &used);
    m_metrics.render(
        used, kind,
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    return image;
}

void Service::serve_image(const httplib::Request& req, httplib::Response& res,
                          const ImageJob& job) {
    const std::string key =
        noise_key(job.id, job.request, job.format, job.kind, job.out_width, job.out_height);
    serve_cached(
        req, res, job.id, key, job.format,
        [&](const render::Cancel& cancel) -> Result<core::Image> {
            render::NoiseRequest q = job.request;
            q.cancel = &cancel;
            const bool resampled =
                job.out_width != job.request.width || job.out_height != job.request.height;
            // The encoder keeps only the format's bits: a GL backend rounds on the GPU and reads
            // back only those (the same bytes). A resampled window needs the floats.
            if (!resampled)
                q.precision = job.format == api::ImageFormat::png     ? render::Precision::u8
                              : job.format == api::ImageFormat::png16 ? render::Precision::u16
                                                                      : render::Precision::f32;
            auto image = job.mix ? render_mix(job.id, q, job.use_region_backend, job.kind)
                                 : render_noise(job.id, q, job.use_region_backend, job.kind);
            if (image && resampled)
                return core::resample_periodic(image.value(), job.out_width, job.out_height);
            return image;
        },
        job.mix, static_cast<std::int64_t>(job.request.width) * job.request.height,
        job.request.mni);
}

// The exemplar's power spectrum (periodic component, centre crop of at most 512 x 512) next to
// that of a window of its texton noise of the same size, on one log scale: where the Gaussian
// model holds they look alike; for a macro-texture (bricks) the exemplar shows peaks the noise
// cannot have.
void Service::spectrum(const httplib::Request& req, const std::string& id, httplib::Response& res) {
    set_route("/v1/textons/{id}/spectrum.png");
    api::NoiseParams noise;
    if (auto e = api::parse_spectrum(id, req.params, noise)) return send_error(res, *e);
    const std::string key =
        "spectrum/" + id + "/s" + std::to_string(noise.seed) + "/m" + mni_text(noise.mni) + ".png";
    serve_cached(
        req, res, id, key, api::ImageFormat::png,
        [&](const render::Cancel& cancel) -> Result<core::Image> {
            auto png = m_store->exemplar_png(id);
            if (!png) return png.error();
            auto exemplar = io::decode_image_memory(png.value());
            if (!exemplar) return exemplar.error();
            const core::Image& u = exemplar.value();
            const int w = std::min(512, u.width), h = std::min(512, u.height);
            core::Image crop(w, h, u.channels);
            for (int c = 0; c < u.channels; ++c)
                for (int y = 0; y < h; ++y)
                    for (int x = 0; x < w; ++x)
                        crop.at(c, x, y) = u.at(c, x + (u.width - w) / 2, y + (u.height - h) / 2);
            render::NoiseRequest nq = noise_request(0, 0, 0, w, h, noise);
            nq.cancel = &cancel;
            auto window = render_noise(id, nq, true, "spectrum");
            if (!window) return window.error();
            const core::Image a = core::centred_power_spectrum(core::periodic_component(crop));
            const core::Image b = core::centred_power_spectrum(window.value());
            const double top = std::max(core::log10_max(a), core::log10_max(b));
            constexpr double kDecades = 5.0;
            const core::Image la = core::log_display(a, top, kDecades);
            const core::Image lb = core::log_display(b, top, kDecades);
            constexpr int kGap = 4;
            core::Image out(2 * w + kGap, h, 1, 1.0f);
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x) {
                    out.at(0, x, y) = la.at(0, x, y);
                    out.at(0, w + kGap + x, y) = lb.at(0, x, y);
                }
            return out;
        },
        false, 512 * 512, noise.mni);
}

void Service::exemplar(const std::string& id, httplib::Response& res) {
    set_route("/v1/textons/{id}/exemplar.png");
    if (auto e = api::check_texton_id(id)) return send_error(res, *e);
    auto png = m_store->exemplar_png(id);
    if (!png) return send_error(res, to_api_error(png.error()));
    res.set_header("Cache-Control", "public, max-age=86400");
    res.set_content(png.value(), "image/png");
}

std::string Service::base_url(const httplib::Request& req) const {
    if (!m_config.public_url.empty()) {
        std::string u = m_config.public_url;
        while (!u.empty() && u.back() == '/') u.pop_back();
        return u;
    }
    std::string host = req.get_header_value("Host");
    const bool sane = !host.empty() && host.size() < 256 &&
                      host.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                             "0123456789.-:[]") == std::string::npos;
    if (!sane) host = m_config.host + ":" + std::to_string(m_port);
    return "http://" + host;
}

void Service::tilejson(const httplib::Request& req, const std::string& id, httplib::Response& res,
                       bool mix) {
    set_route(mix ? "/v1/mixes/{id}/tilejson.json" : "/v1/textons/{id}/tilejson.json");
    api::TileRequest probe; // seed, mni and size, checked exactly as the tiles will check them
    if (auto e = api::parse_tilejson(id, req.params, probe)) return send_error(res, *e);
    if (mix) {
        if (auto meta = m_mixes->meta(id); !meta)
            return send_error(res, to_api_error(meta.error()));
    } else if (auto meta = m_store->find(id); !meta) {
        return send_error(res, to_api_error(meta.error()));
    }
    const std::string prefix = mix ? "/v1/mixes/" : "/v1/textons/";
    const std::string query = "?seed=" + std::to_string(probe.noise.seed) +
                              "&mni=" + mni_text(probe.noise.mni) +
                              (probe.size != 256 ? "&size=" + std::to_string(probe.size) : "");
    const std::string base = base_url(req);
    const int native_zoom = api::kMapMaxLevel; // level 0: one texel per pixel
    nlohmann::json j = {
        {"tilejson", "3.0.0"},
        {"name", "textond " + id.substr(0, 12)},
        {"description", std::string(mix ? "Texture mix " : "Texton noise of texton ") + id +
                            " (seed " + std::to_string(probe.noise.seed) + ", MNI " +
                            mni_text(probe.noise.mni) + "), an unbounded seamless plane"},
        {"version", "1.0.0"},
        {"scheme", "xyz"},
        {"tiles", {base + prefix + id + "/map/{z}/{x}/{y}.png" + query}},
        {"minzoom", 0},
        {"maxzoom", api::kMapMaxZoom},
        {"center", {0, 0, native_zoom}},
        {"textond",
         {{"tile_size", probe.size},
          {"level_of_zoom", "level = " + std::to_string(api::kMapMaxLevel) +
                                " - z: zoom z shows 2^(24 - z) texels per pixel; z = 24 is "
                                "the texton's own resolution"},
          {"native_zoom", native_zoom},
          {"crs", "Leaflet L.CRS.Simple / OpenLayers pixel projection; y grows downwards"},
          {"game_tiles", base + prefix + id + "/tiles/{level}/{x}/{y}.png" + query}}}};
    // The absolute URLs come from the Host header unless --public-url is set.
    if (m_config.public_url.empty()) res.set_header("Vary", "Host");
    send_json(res, 200, j, "public, max-age=60");
}

void Service::install_image_routes() {
    using Req = const httplib::Request&;
    using Res = httplib::Response&;
    // Game tiles (z = level) and web-map tiles (z = zoom, level = 24 - z) differ only in parsing.
    using TileParser = decltype(&api::parse_tile);
    auto tile_route = [this](const char* route, TileParser parse, bool mix = false) {
        return [this, route, parse, mix](Req req, Res res) {
            set_route(route);
            api::TileRequest t;
            if (auto e = parse(req.matches[1].str(), req.matches[2].str(), req.matches[3].str(),
                               req.matches[4].str(), req.matches[5].str(), req.params, t))
                return send_error(res, *e);
            serve_image(req, res,
                        {t.id, "tile", t.format,
                         noise_request(t.level, t.x0(), t.y0(), t.size, t.size, t.noise), t.size,
                         t.size, false, mix});
        };
    };
    auto region_route = [this](const char* route, bool mix) {
        return [this, route, mix](Req req, Res res) {
            set_route(route);
            api::RegionRequest r;
            if (auto e = api::parse_region(req.matches[1].str(), req.matches[2].str(), req.params,
                                           m_config.limits, r))
                return send_error(res, *e);
            serve_image(req, res,
                        {r.id, "region", r.format,
                         noise_request(r.level, r.x, r.y, r.width, r.height, r.noise), r.width,
                         r.height, true, mix});
        };
    };
    // Texture mixes: the same windows onto their (non-stationary) noise.
    m_http.Get(R"(/v1/mixes/([^/]+)/tiles/([^/]+)/([^/]+)/([^/.]+)\.([a-z0-9]+))",
               tile_route("/v1/mixes/{id}/tiles/{z}/{x}/{y}.{format}", &api::parse_tile, true));
    m_http.Get(R"(/v1/mixes/([^/]+)/map/([^/]+)/([^/]+)/([^/.]+)\.([a-z0-9]+))",
               tile_route("/v1/mixes/{id}/map/{z}/{x}/{y}.{format}", &api::parse_map_tile, true));
    m_http.Get(R"(/v1/mixes/([^/]+)/region\.([a-z0-9]+))",
               region_route("/v1/mixes/{id}/region.{format}", true));
    m_http.Get(R"(/v1/mixes/([^/]+)/tilejson\.json)",
               [this](Req req, Res res) { tilejson(req, req.matches[1].str(), res, true); });
    m_http.Get(R"(/v1/textons/([^/]+)/tiles/([^/]+)/([^/]+)/([^/.]+)\.([a-z0-9]+))",
               tile_route("/v1/textons/{id}/tiles/{z}/{x}/{y}.{format}", &api::parse_tile));
    m_http.Get(R"(/v1/textons/([^/]+)/map/([^/]+)/([^/]+)/([^/.]+)\.([a-z0-9]+))",
               tile_route("/v1/textons/{id}/map/{z}/{x}/{y}.{format}", &api::parse_map_tile));
    m_http.Get(R"(/v1/textons/([^/]+)/region\.([a-z0-9]+))",
               region_route("/v1/textons/{id}/region.{format}", false));
    m_http.Get(R"(/v1/textons/([^/]+)/tileable\.([a-z0-9]+))", [this](Req req, Res res) {
        set_route("/v1/textons/{id}/tileable.{format}");
        api::TileableRequest t;
        if (auto e = api::parse_tileable(req.matches[1].str(), req.matches[2].str(), req.params,
                                         m_config.limits, t))
            return send_error(res, *e);
        auto meta = m_store->find(t.id);
        if (!meta) return send_error(res, to_api_error(meta.error()));
        // The noise repeats every P cells of side a; the nearest whole number of cells is
        // rendered and resampled by its Fourier series to exactly w x h (still periodic).
        const int a = core::noise::cell_size(meta.value().size);
        const auto cells = [a](int n) { return std::max(1, (n + a / 2) / a); };
        render::NoiseRequest q =
            noise_request(0, 0, 0, cells(t.width) * a, cells(t.height) * a, t.noise);
        q.period = {cells(t.width), cells(t.height)};
        serve_image(req, res, {t.id, "tileable", t.format, q, t.width, t.height, true});
    });
    m_http.Get(R"(/v1/textons/([^/]+)/spectrum\.png)",
               [this](Req req, Res res) { spectrum(req, req.matches[1].str(), res); });
    m_http.Get(R"(/v1/textons/([^/]+)/exemplar\.png)",
               [this](Req req, Res res) { exemplar(req.matches[1].str(), res); });
    m_http.Get(R"(/v1/textons/([^/]+)/tilejson\.json)",
               [this](Req req, Res res) { tilejson(req, req.matches[1].str(), res); });
}

} // namespace textond::http
