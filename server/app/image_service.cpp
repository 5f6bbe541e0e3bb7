#include "server/app/image_service.h"

#include "api/noise_fields.h"

#include "core/grid_poisson.h"
#include "core/noise_levels.h"
#include "core/periodic_component.h"
#include "core/periodic_resample.h"
#include "core/power_spectrum.h"
#include "render/normal_map.h"
#include "server/app/build_id.h"
#include "server/io/image_io.h"
#include "server/io/sha256.h"
#include "server/io/web_image.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace textond::app {

using Work = render::Renderer::Work;

namespace {

io::Encoding encoding_of(api::ImageFormat f) {
    switch (f) {
    case api::ImageFormat::png:
        return io::Encoding::png8;
    case api::ImageFormat::png16:
        return io::Encoding::png16;
    case api::ImageFormat::exr:
        return io::Encoding::exr;
    case api::ImageFormat::webp: // encoded by libwebp and libavif (ImageService::encode)
    case api::ImageFormat::avif:
        break;
    }
    return io::Encoding::png8;
}

// The centre crop of at most w x h of an image.
core::Image centre_crop(const core::Image& u, int w, int h) {
    core::Image crop(w, h, u.channels);
    for (int c = 0; c < u.channels; ++c)
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                crop.at(c, x, y) = u.at(c, x + (u.width - w) / 2, y + (u.height - h) / 2);
    return crop;
}

// Two power spectra side by side on one log scale of five decades, a gap of 4 pixels between.
core::Image side_by_side(const core::Image& a, const core::Image& b) {
    const double top = std::max(core::log10_max(a), core::log10_max(b));
    constexpr double kDecades = 5.0;
    const core::Image la = core::log_display(a, top, kDecades);
    const core::Image lb = core::log_display(b, top, kDecades);
    constexpr int kGap = 4;
    const int w = a.width, h = a.height;
    core::Image out(2 * w + kGap, h, 1, 1.0f);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            out.at(0, x, y) = la.at(0, x, y);
            out.at(0, w + kGap + x, y) = lb.at(0, x, y);
        }
    return out;
}

} // namespace

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
    q.marginals =
        noise.exemplar_marginals ? render::Marginals::exemplar : render::Marginals::gaussian;
    return q;
}

Result<core::Image> render_view(render::Renderer& renderer, const PreparedSet& set,
                                const api::MapChoice& map, const render::NoiseRequest& q,
                                render::Renderer::Work work, std::string* used) {
    if (map.encoding) { // the height in floats, then its metres as RGB bytes
        api::MapChoice height = map;
        height.encoding.reset();
        render::NoiseRequest f = q;
        f.precision = render::Precision::f32;
        auto h = render_view(renderer, set, height, f, work, used);
        if (!h) return h;
        return core::encode_elevation(h.value(), *map.encoding, map.height_scale);
    }
    if (map.name == core::kLitMap) {
        if (set && set.value()->texton().maps.empty())
            return make_error(ErrorCode::invalid_argument,
                              "map=lit needs a material set with a height map; this texton has "
                              "one exemplar");
        if (set && !core::find_map(set.value()->texton().maps, "albedo"))
            return make_error(ErrorCode::invalid_argument,
                              "map=lit needs the set's albedo, which it does not have");
        auto albedo = render::map_view(set, "");
        if (!albedo) return albedo.error();
        auto height = render::map_view(set, core::kNormalMap);
        if (!height) return height.error();
        if (auto err = height.value()->check(q)) return *err;
        auto colour = renderer.noise(*albedo.value(), q, work, used);
        if (!colour) return colour;
        auto normals = renderer.normals(*height.value(), q, map.strength, work);
        if (!normals) return normals;
        return render::shade_lit(colour.value(), normals.value(), map.azimuth, map.elevation);
    }
    auto prepared = render::map_view(set, map.name);
    if (!prepared) return prepared.error();
    if (auto err = prepared.value()->check(q)) return *err;
    if (map.name == core::kNormalMap) {
        if (used) *used = "cpu";
        return renderer.normals(*prepared.value(), q, map.strength, work);
    }
    return renderer.noise(*prepared.value(), q, work, used);
}

Result<std::string> encode_image(const core::Image& image, api::ImageFormat format, int quality,
                                 const std::string& id, int png_compression) {
    if (format == api::ImageFormat::webp) return io::encode_webp(image, quality);
    if (format == api::ImageFormat::avif)
        return io::encode_avif(image, quality > 0 ? quality : io::kDefaultAvifQuality);
    return io::encode_image_memory(
        image, encoding_of(format),
        {{"textond:noise", render::kNoiseVersion}, {"textond:texton", id}}, png_compression);
}

ImageService::ImageService(store::TextonStore& textons, store::MixStore& mixes,
                           store::SplatStore& splats, render::Renderer& renderer, Metrics& metrics,
                           int png_compression)
    : m_textons(textons), m_mixes(mixes), m_splats(splats), m_renderer(renderer),
      m_metrics(metrics), m_png_compression(png_compression) {}

std::string ImageService::key(const Job& job) {
    const render::NoiseRequest& q = job.request;
    return std::string(job.kind) + "/" + job.id + "/" + std::to_string(q.level) + "/" +
           std::to_string(q.x0) + "/" + std::to_string(q.y0) + "/" + std::to_string(q.width) + "x" +
           std::to_string(q.height) + "/p" + std::to_string(q.period[0]) + "x" +
           std::to_string(q.period[1]) + "/o" + std::to_string(job.out_width) + "x" +
           std::to_string(job.out_height) + "/" + api::noise_query(job.noise, api::kTileRoute) +
           (job.quality != api::kDefaultQuality ? "/q" + std::to_string(job.quality) : "") + "." +
           api::extension(job.format);
}

std::string ImageService::spectrum_key(const std::string& id, const api::NoiseParams& noise) {
    return "spectrum/" + id + "/" + api::noise_query(noise, api::kReportRoute) + ".png";
}

std::string ImageService::etag(const std::string& key) const {
    io::Sha256 h;
    h.update(build_id()).update("\n").update(m_renderer.identity()).update("\n").update(key);
    return "\"" + h.hex().substr(0, 40) + "\"";
}

Result<int> ImageService::interpolation_order(const std::string& id, Source source) const {
    if (source == Source::splat) {
        auto found = m_splats.prepared(id);
        if (!found) return found.error();
        return found.value()->order();
    }
    if (source == Source::mix) {
        auto found = m_mixes.meta(id);
        if (!found) return found.error();
        return found.value().order;
    }
    auto found = m_textons.find(id);
    if (!found) return found.error();
    return found.value().order;
}

Result<ImageService::Job> ImageService::tileable(const api::TileableRequest& t) const {
    auto meta = m_textons.find(t.id);
    if (!meta) return meta.error();
    // The noise repeats every P cells of side a; the nearest whole number of cells is rendered
    // and resampled by its Fourier series to exactly w x h (still periodic).
    const int a = core::noise::cell_size(meta.value().size);
    const auto cells = [a](int n) { return std::max(1, (n + a / 2) / a); };
    render::NoiseRequest q =
        noise_request(0, 0, 0, cells(t.width) * a, cells(t.height) * a, t.noise);
    q.period = {cells(t.width), cells(t.height)};
    return Job{t.id,     "tileable", t.format,       q,       t.width,
               t.height, true,       Source::texton, t.noise, t.quality};
}

Result<core::Image> ImageService::evaluate(const std::string& id, const render::NoiseRequest& q,
                                           Source source, bool whole_machine, const char* kind,
                                           const api::MapChoice& map) {
    const Work work = whole_machine ? Work::frame : Work::tile;
    if (source != Source::texton && !map.name.empty())
        return make_error(ErrorCode::invalid_argument, source == Source::mix
                                                           ? "a texture mix has no maps: drop map="
                                                           : "a splat map has no maps: drop map=");
    if (source == Source::splat) {
        auto prepared = m_splats.prepared(id);
        if (!prepared) return prepared.error();
        if (auto err = prepared.value()->check(q)) return *err;
        return timed(kind, [&](std::string* used) {
            return m_renderer.splat(*prepared.value(), q, work, used);
        });
    }
    if (source == Source::mix) {
        auto prepared = m_mixes.prepared(id);
        if (!prepared) return prepared.error();
        if (auto err = prepared.value()->check(q)) return *err;
        return timed(kind, [&](std::string* used) {
            return m_renderer.mix(*prepared.value(), q, work, used);
        });
    }
    const auto set = m_textons.prepared(id);
    return timed(
        kind, [&](std::string* used) { return render_view(m_renderer, set, map, q, work, used); });
}

Result<core::Image>
ImageService::timed(const char* kind,
                    const std::function<Result<core::Image>(std::string*)>& evaluate) {
    const auto t0 = std::chrono::steady_clock::now();
    std::string used;
    Result<core::Image> image = evaluate(&used);
    if (!used.empty()) // empty: refused before any backend ran
        m_metrics.render(
            used, kind,
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count());
    return image;
}

Result<core::Image> ImageService::render(const Job& job, const render::Cancel& cancel) {
    render::NoiseRequest q = job.request;
    q.cancel = &cancel;
    const bool resampled =
        job.out_width != job.request.width || job.out_height != job.request.height;
    // The encoder keeps only the format's bits: a GL backend rounds on the GPU and reads back
    // only those (the same bytes). A resampled window needs the floats.
    if (!resampled)
        q.precision = job.format == api::ImageFormat::png16 ? render::Precision::u16
                      : job.format == api::ImageFormat::exr ? render::Precision::f32
                                                            : render::Precision::u8;
    auto image = evaluate(job.id, q, job.source, job.whole_machine, job.kind, job.noise.map);
    if (!image || !resampled) return image;
    if (job.noise.map.encoding) // the parsers allow no resampled window of elevation bytes
        return make_error(ErrorCode::internal, "elevation tiles are never resampled");
    core::Image out = core::resample_periodic(image.value(), job.out_width, job.out_height);
    // Resampling mixes neighbouring normals: unit length again.
    if (job.noise.map.name == core::kNormalMap) render::renormalise_normal_map(out);
    return out;
}

// Where the Gaussian model holds the two spectra look alike; for a macro-texture (bricks) the
// exemplar shows peaks the noise cannot have.
Result<core::Image> ImageService::spectrum(const std::string& id, const api::NoiseParams& noise,
                                           const render::Cancel& cancel) {
    auto png = m_textons.exemplar_png(id);
    if (!png) return png.error();
    auto exemplar = io::decode_image_memory(png.value());
    if (!exemplar) return exemplar.error();
    const core::Image& u = exemplar.value();
    const int w = std::min(512, u.width), h = std::min(512, u.height);
    render::NoiseRequest q = noise_request(0, 0, 0, w, h, noise);
    q.cancel = &cancel;
    auto window = evaluate(id, q, Source::texton, true, "spectrum");
    if (!window) return window.error();
    return side_by_side(
        core::centred_power_spectrum(core::periodic_component(centre_crop(u, w, h))),
        core::centred_power_spectrum(window.value()));
}

std::string ImageService::quality_key(const std::string& id, const api::NoiseParams& noise) {
    return "quality/" + id + "/" + api::noise_query(noise, api::kReportRoute) + ".png";
}

Result<QualityReport> ImageService::quality(const std::string& id, const api::NoiseParams& noise,
                                            const render::Cancel& cancel) {
    auto meta = m_textons.find(id);
    if (!meta) return meta.error();
    auto png = m_textons.exemplar_png(id);
    if (!png) return png.error();
    auto exemplar = io::decode_image_memory(png.value());
    if (!exemplar) return exemplar.error();
    const core::Image& u = exemplar.value();
    const int w = std::min(256, u.width), h = std::min(256, u.height);
    render::NoiseRequest q = noise_request(0, 0, 0, w, h, noise);
    q.cancel = &cancel;
    auto gaussian = evaluate(id, q, Source::texton, true, "quality");
    if (!gaussian) return gaussian.error();
    core::Image restored;
    if (meta.value().exemplar_marginals) {
        q.marginals = render::Marginals::exemplar;
        auto r = evaluate(id, q, Source::texton, true, "quality");
        if (!r) return r.error();
        restored = std::move(r.value());
    }
    return quality_report(meta.value(), centre_crop(u, w, h), gaussian.value(), restored);
}

Result<int> ImageService::splat_layers(const std::string& id) const {
    auto found = m_splats.prepared(id);
    if (!found) return found.error();
    return found.value()->layers();
}

Result<core::Image> ImageService::splat_report(const std::string& id, const api::NoiseParams& noise,
                                               const render::Cancel& cancel) {
    auto prepared = m_splats.prepared(id);
    if (!prepared) return prepared.error();
    const render::PreparedSplat& s = *prepared.value();
    constexpr int kSide = 256, kGap = 4;
    int level = 2;
    std::int64_t x0 = 0, y0 = 0;
    if (s.weights().kind == core::SplatWeights::Kind::image) {
        // The coarsest level whose 256 pixels span the weight image, from its corner.
        const core::SplatImage& im = s.weights().image;
        const double extent = im.scale * std::max(im.weights.width, im.weights.height);
        level = 0;
        while (level < core::noise::kMaxLevel && std::ldexp(kSide, level) < extent) ++level;
        x0 = static_cast<std::int64_t>(std::floor(std::ldexp(im.x0, -level)));
        y0 = static_cast<std::int64_t>(std::floor(std::ldexp(im.y0, -level)));
    }
    render::NoiseRequest q = noise_request(level, x0, y0, kSide, kSide, noise);
    q.cancel = &cancel;
    auto weights = m_renderer.splat_weights(s, q, Work::frame);
    if (!weights) return weights.error();
    auto result = evaluate(id, q, Source::splat, true, "quality");
    if (!result) return result.error();
    core::Image out(2 * kSide + kGap, kSide, 3, 1.0f);
    for (int y = 0; y < kSide; ++y)
        for (int x = 0; x < kSide; ++x)
            for (int c = 0; c < 3; ++c) {
                double v = 0;
                for (int k = 0; k < s.layers(); ++k)
                    v += weights.value().at(k, x, y) * splat_palette(k)[c];
                out.at(c, x, y) = static_cast<float>(v);
                out.at(c, kSide + kGap + x, y) =
                    result.value().at(std::min(c, result.value().channels - 1), x, y);
            }
    return out;
}

const float* splat_palette(int layer) {
    // Distinct under the common colour-vision deficiencies (Okabe and Ito), layer 1 first.
    static const float kPalette[core::kMaxSplatLayers][3] = {
        {0.90f, 0.62f, 0.00f}, {0.34f, 0.71f, 0.91f}, {0.00f, 0.62f, 0.45f}, {0.94f, 0.89f, 0.26f},
        {0.00f, 0.45f, 0.70f}, {0.84f, 0.37f, 0.00f}, {0.80f, 0.47f, 0.65f}, {0.60f, 0.60f, 0.60f}};
    return kPalette[layer];
}

Result<std::string> ImageService::encode(const core::Image& image, api::ImageFormat format,
                                         int quality, const std::string& id) const {
    return encode_image(image, format, quality, id, m_png_compression);
}

} // namespace textond::app
