#include "server/app/image_service.h"

#include "api/noise_fields.h"
#include "core/grid_poisson.h"
#include "core/periodic_resample.h"
#include "render/image_buffers.h"
#include "render/normal_map.h"
#include "server/app/build_id.h"
#include "server/io/image_io.h"
#include "server/io/sha256.h"
#include "server/io/web_image.h"

#include <algorithm>

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

} // namespace

Result<std::string> encode_image(core::Image&& image, api::ImageFormat format, int quality,
                                 const std::string& id, int png_compression,
                                 const std::function<bool()>& stop) {
    if (format == api::ImageFormat::webp || format == api::ImageFormat::avif) {
        // The encoders read 8-bit RGB only: the floats (12 bytes a pixel) go before libaom's
        // frame buffers (about 34 bytes a pixel) come (deploy/README.md "Memory bound").
        auto rgb = io::take_rgb8(image);
        render::recycle_image(std::move(image)); // what is left of it: floats, or nothing
        if (!rgb) return rgb.error();
        if (format == api::ImageFormat::webp)
            return io::encode_webp(std::move(rgb.value()), quality, stop);
        return io::encode_avif(std::move(rgb.value()),
                               quality > 0 ? quality : io::kDefaultAvifQuality);
    }
    auto bytes = io::encode_image_memory(
        image, encoding_of(format),
        {{"textond:noise", render::kNoiseVersion}, {"textond:texton", id}}, png_compression);
    render::recycle_image(std::move(image)); // the pixels go before the bytes are cached
    return bytes;
}

ImageService::ImageService(TextonSource& textons, render::Renderer& renderer, int png_compression)
    : m_textons(textons), m_renderer(renderer), m_png_compression(png_compression) {}

std::string ImageService::key(const Job& job) {
    const render::NoiseRequest& q = job.request;
    return std::string(job.source->collection()) + "/" + job.kind + "/" + job.id + "/" +
           std::to_string(q.level) + "/" + std::to_string(q.x0) + "/" + std::to_string(q.y0) + "/" +
           std::to_string(q.width) + "x" + std::to_string(q.height) + "/p" +
           std::to_string(q.period[0]) + "x" + std::to_string(q.period[1]) + "/o" +
           std::to_string(job.out_width) + "x" + std::to_string(job.out_height) + "/" +
           api::noise_query(job.noise, api::kTileRoute) +
           (job.quality != api::kDefaultQuality ? "/q" + std::to_string(job.quality) : "") + "." +
           api::extension(job.format);
}

std::string ImageService::report_key(const ImageSource& source, const std::string& id,
                                     const api::NoiseParams& noise) {
    return std::string(source.collection()) + "/report/" + id + "/" +
           api::noise_query(noise, api::kReportRoute) + ".png";
}

std::string ImageService::etag(const std::string& key) const {
    io::Sha256 h;
    h.update(build_id()).update("\n").update(m_renderer.identity()).update("\n").update(key);
    return "\"" + h.hex().substr(0, 40) + "\"";
}

Result<ImageService::Job> ImageService::tileable(const api::TileableRequest& t) const {
    auto meta = m_textons.store().find(t.id);
    if (!meta) return meta.error();
    // The noise repeats every P cells of side a; the nearest whole number of cells is rendered
    // and resampled by its Fourier series to exactly w x h (still periodic).
    const int a = core::noise::cell_size(meta.value().size);
    const auto cells = [a](int n) { return std::max(1, (n + a / 2) / a); };
    render::NoiseRequest q =
        to_noise_request(0, 0, 0, cells(t.width) * a, cells(t.height) * a, t.noise);
    q.period = {cells(t.width), cells(t.height)};
    return Job{t.id,     "tileable", t.format,   q,       t.width,
               t.height, true,       &m_textons, t.noise, t.quality};
}

Result<core::Image> ImageService::render(const Job& job, const render::Cancel& cancel) {
    render::NoiseRequest q = job.request;
    q.cancel = &cancel;
    const bool resampled =
        job.out_width != job.request.width || job.out_height != job.request.height;
    // The encoder keeps only the format's bits: a GL backend rounds on the GPU and reads back
    // only those (the same bytes). A resampled window needs the floats.
    if (!resampled) {
        q.precision = job.format == api::ImageFormat::png16 ? render::Precision::u16
                      : job.format == api::ImageFormat::exr ? render::Precision::f32
                                                            : render::Precision::u8;
        // And at 8 bits the bytes themselves, which every 8-bit encoder takes as they are.
        q.bytes = q.precision == render::Precision::u8;
    }
    auto image = job.source->window(job.id, q, job.whole_machine ? Work::frame : Work::tile,
                                    job.kind, job.noise.map);
    if (!image || !resampled) return image;
    if (job.noise.map.encoding) // the parsers allow no resampled window of elevation bytes
        return make_error(ErrorCode::internal, "elevation tiles are never resampled");
    core::Image out = core::resample_periodic(image.value(), job.out_width, job.out_height);
    // Resampling mixes neighbouring normals: unit length again.
    if (job.noise.map.name == core::kNormalMap) render::renormalise_normal_map(out);
    return out;
}

Result<std::string> ImageService::encode(core::Image&& image, api::ImageFormat format, int quality,
                                         const std::string& id,
                                         const std::function<bool()>& stop) const {
    return encode_image(std::move(image), format, quality, id, m_png_compression, stop);
}

} // namespace textond::app
