#pragma once
// The image workflow without HTTP: a window onto a texton's (or a mix's) noise, evaluated on the
// renderer in the caller's slot, resampled when a tileable texture asks for it, encoded, and named
// by a key and an ETag that cover everything that changes a byte. The routes (image_routes.h) add
// the cache, admission and the answer.
#include "api/requests.h"
#include "core/image.h"
#include "core/result.h"
#include "render/cancel.h"
#include "render/noise_request.h"
#include "render/prepared_texton.h"
#include "render/renderer.h"
#include "server/app/metrics.h"
#include "server/app/quality_report.h"
#include "server/store/mix_store.h"
#include "server/store/splat_store.h"
#include "server/store/texton_store.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

namespace textond::app {

render::NoiseRequest noise_request(int level, std::int64_t x0, std::int64_t y0, int w, int h,
                                   const api::NoiseParams& noise);

using PreparedSet = Result<std::shared_ptr<const render::PreparedTexton>>;

// The pixels of a view (api::MapChoice) of a texton or material set: the texton's noise, a set's
// map, its normals or its lit albedo. `used` names the backend that ran; it stays empty when
// the request was refused before any did.
Result<core::Image> render_view(render::Renderer& renderer, const PreparedSet& set,
                                const api::MapChoice& map, const render::NoiseRequest& q,
                                render::Renderer::Work work, std::string* used);

// An image's bytes in an API format, tagged (PNG, EXR) with the noise version and the id: what
// every image endpoint and `textond export` write.
Result<std::string> encode_image(const core::Image& image, api::ImageFormat format, int quality,
                                 const std::string& id, int png_compression);

// The colour (RGB in [0, 1]) of splat layer `layer` (0..7) in a splat's report.
const float* splat_palette(int layer);

// What an image's id names: a texton (or material set), a texture mix or a splat map.
enum class Source { texton, mix, splat };

class ImageService {
public:
    ImageService(store::TextonStore& textons, store::MixStore& mixes, store::SplatStore& splats,
                 render::Renderer& renderer, Metrics& metrics, int png_compression);

    struct Job {
        std::string id;
        const char* kind = "tile"; // tile | region | tileable (metrics label)
        api::ImageFormat format = api::ImageFormat::png;
        render::NoiseRequest request;
        int out_width = 0, out_height = 0; // tileable textures are resampled to the asked size
        bool whole_machine = false;        // regions and tileables: the frame backend
        Source source = Source::texton;
        api::NoiseParams noise; // seed, mni, marginals (also in request) and the view (map=)
        int quality = api::kDefaultQuality; // of lossy WebP and AVIF
        std::int64_t pixels() const { return std::int64_t{request.width} * request.height; }
    };
    // One key per distinct image: everything that changes a pixel or a byte of it.
    static std::string key(const Job& job);
    static std::string spectrum_key(const std::string& id, const api::NoiseParams& noise);
    // The strong ETag of a key's bytes: the build, the renderer's identity and the key.
    std::string etag(const std::string& key) const;

    // The stored texton's (mix's, splat's) interpolation order, which admission costs a window
    // at; not_found when there is none, so it is also the routes' first existence check.
    Result<int> interpolation_order(const std::string& id, Source source) const;
    // A splat's layers over one pixel's worth of work: what admission multiplies a window by.
    Result<int> splat_layers(const std::string& id) const;
    // The job of a tileable texture: the nearest whole number of cells, resampled to w x h.
    Result<Job> tileable(const api::TileableRequest& t) const;

    // The job's pixels, in the caller's slot.
    Result<core::Image> render(const Job& job, const render::Cancel& cancel);
    // The exemplar's power spectrum beside that of a window of its noise, on one log scale.
    Result<core::Image> spectrum(const std::string& id, const api::NoiseParams& noise,
                                 const render::Cancel& cancel);
    // The texton's quality report (quality_report.h): its exemplar's centre crop (at most
    // 256 x 256) beside level-0 windows of its noise, Gaussian and restored.
    Result<QualityReport> quality(const std::string& id, const api::NoiseParams& noise,
                                  const render::Cancel& cancel);
    static std::string quality_key(const std::string& id, const api::NoiseParams& noise);
    // A splat's report: its weights (each layer a colour of splat_palette) beside its render, one
    // 256 x 256 window at the level that shows the whole weight image (level 2 for rules).
    Result<core::Image> splat_report(const std::string& id, const api::NoiseParams& noise,
                                     const render::Cancel& cancel);
    // The image's bytes in `format`, tagged with the noise version and the id.
    Result<std::string> encode(const core::Image& image, api::ImageFormat format, int quality,
                               const std::string& id) const;

private:
    Result<core::Image> evaluate(const std::string& id, const render::NoiseRequest& q,
                                 Source source, bool whole_machine, const char* kind,
                                 const api::MapChoice& map = {});
    // Runs `evaluate` and adds its time to the render histogram of the backend it names.
    Result<core::Image> timed(const char* kind,
                              const std::function<Result<core::Image>(std::string*)>& evaluate);

    store::TextonStore& m_textons;
    store::MixStore& m_mixes;
    store::SplatStore& m_splats;
    render::Renderer& m_renderer;
    Metrics& m_metrics;
    const int m_png_compression;
};

} // namespace textond::app
