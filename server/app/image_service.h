#pragma once
// The image workflow without HTTP: a window onto one source's image (image_source.h: a texton's,
// a mix's or a splat's), resampled when a tileable texture asks for it, encoded, and named by a
// key and an ETag that cover everything that changes a byte. The routes (image_routes.h) add the
// cache, admission and the answer.
#include "api/requests.h"
#include "core/image.h"
#include "core/result.h"
#include "render/cancel.h"
#include "render/noise_request.h"
#include "render/renderer.h"
#include "server/app/image_source.h"
#include "server/app/texton_source.h"

#include <cstdint>
#include <functional>
#include <string>

namespace textond::app {

// An image's bytes in an API format, tagged (PNG, EXR) with the noise version and the id: what
// every image endpoint and `textond export` write. The pixels are released (recycled) as soon as
// the encoder no longer needs them, before it has finished.
// `stop` abandons a WebP encode (cancelled) once it is true (the image routes': their client gone).
Result<std::string> encode_image(core::Image&& image, api::ImageFormat format, int quality,
                                 const std::string& id, int png_compression,
                                 const std::function<bool()>& stop = {});

class ImageService {
public:
    // `textons`: the source of tileable textures.
    ImageService(TextonSource& textons, render::Renderer& renderer, int png_compression);

    struct Job {
        std::string id;
        const char* kind = "tile"; // tile | region | tileable (metrics label)
        api::ImageFormat format = api::ImageFormat::png;
        render::NoiseRequest request;
        int out_width = 0, out_height = 0; // tileable textures are resampled to the asked size
        bool whole_machine = false;        // regions and tileables: the frame backend
        ImageSource* source = nullptr;     // what the id names
        api::NoiseParams noise; // seed, mni, marginals (also in request) and the view (map=)
        int quality = api::kDefaultQuality; // of lossy WebP and AVIF
        std::int64_t pixels() const { return std::int64_t{request.width} * request.height; }
    };
    // One key per distinct image: everything that changes a pixel or a byte of it.
    static std::string key(const Job& job);
    static std::string report_key(const ImageSource& source, const std::string& id,
                                  const api::NoiseParams& noise);
    // The strong ETag of a key's bytes: the build, the renderer's identity and the key.
    std::string etag(const std::string& key) const;

    // The job of a tileable texture: the nearest whole number of cells, resampled to w x h.
    Result<Job> tileable(const api::TileableRequest& t) const;

    // The job's pixels, in the caller's slot.
    Result<core::Image> render(const Job& job, const render::Cancel& cancel);
    // The image's bytes in `format`, tagged with the noise version and the id; the pixels are
    // recycled as encode_image says.
    Result<std::string> encode(core::Image&& image, api::ImageFormat format, int quality,
                               const std::string& id, const std::function<bool()>& stop = {}) const;

private:
    TextonSource& m_textons;
    render::Renderer& m_renderer;
    const int m_png_compression;
};

} // namespace textond::app
