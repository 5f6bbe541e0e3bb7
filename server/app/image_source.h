#pragma once
// What an image's id names: a texton (or material set), a texture mix or a splat map, behind one
// interface (as Martin's tile-server Source: one get_tile and one tilejson per kind). Each kind is
// a class beside this one (texton_source.h, mix_source.h, splat_source.h). The server builds one
// of each (TextondServer::make_services) and installs the same image routes for every one
// (routes.cpp, install_image_routes); the image routes and ImageService never branch on the kind.
// A fourth kind is one more class and one more line in make_services, beside its store and its
// create, get and delete routes (server/README.md "Adding a kind of image").
#include "api/requests.h"
#include "core/image.h"
#include "core/result.h"
#include "render/cancel.h"
#include "render/noise_request.h"
#include "render/renderer.h"
#include "server/app/metrics.h"

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

namespace textond::app {

// The window of a request on the plane, with its noise's seed, density and marginals.
render::NoiseRequest to_noise_request(int level, std::int64_t x0, std::int64_t y0, int w, int h,
                                      const api::NoiseParams& noise);

class ImageSource {
public:
    using Work = render::Renderer::Work;
    ImageSource(render::Renderer& renderer, Metrics& metrics)
        : m_renderer(renderer), m_metrics(metrics) {}
    virtual ~ImageSource() = default;
    ImageSource(const ImageSource&) = delete;
    ImageSource& operator=(const ImageSource&) = delete;
    ImageSource(ImageSource&&) = delete;
    ImageSource& operator=(ImageSource&&) = delete;

    // Its collection under /v1/ ("textons"): the prefix of its routes and of its images' keys.
    virtual const char* collection() const = 0;
    // Its TileJSON's description up to the id ("Texture mix ").
    virtual const char* described_as() const = 0;
    // Whether its images take map= and the map's fields (a material set's views): the
    // allow-list its routes parse with (api/noise_fields.h).
    virtual bool has_maps() const = 0;
    // Whether it has a report (GET .../{id}/quality.png).
    virtual bool has_report() const = 0;

    // The stored id's interpolation order, which admission costs a window at; not_found when
    // there is none, so it is also the routes' first existence check.
    virtual Result<int> interpolation_order(const std::string& id) const = 0;
    // What admission costs a window of view `map` at: the renders it takes (its pixels times
    // these), the share of that work on the CPU whatever the backend, and the interpolation
    // order; not_found when the id is not stored (found once for the estimate and existence).
    struct WindowCost {
        int passes = 1;
        double cpu_share = 0;
        int textons = 1; // texton windows rendered (a splat's layers)
        int size = 0;    // the smallest texton size among them: its zoomed-out levels list most
        int order = 1;
    };
    virtual Result<WindowCost> cost(const std::string& id, const api::MapChoice& map) const = 0;
    // What its tiles would refuse (marginals or a map the id does not have, an unknown id),
    // refused once by its TileJSON.
    virtual std::optional<Error> tilejson_refusal(const std::string& id,
                                                  const api::NoiseParams& noise) const = 0;

    // A window of the id's image (view `map`), evaluated on the renderer in the caller's slot.
    // Its time goes to the render histogram of the backend that ran, under `kind`.
    Result<core::Image> window(const std::string& id, const render::NoiseRequest& q, Work work,
                               const char* kind, const api::MapChoice& map = {});
    // Its report (has_report), rendered in the caller's slot, and the pixels of work admission
    // costs it at (its windows, not the image's size).
    virtual Result<std::int64_t> report_work_pixels(const std::string& id) const;
    virtual Result<core::Image> report(const std::string& id, const api::NoiseParams& noise,
                                       const render::Cancel& cancel);

protected:
    // A window ready to run on the renderer; `used` names the backend that ran (empty when it
    // refused before any did).
    using Evaluate = std::function<Result<core::Image>(std::string* used)>;
    // The id's window prepared: its stored model loaded and, where the kind can before the
    // render, checked against q and `map` (a texton's views refuse inside the Evaluate).
    virtual Result<Evaluate> prepare(const std::string& id, const render::NoiseRequest& q,
                                     Work work, const api::MapChoice& map) = 0;

    render::Renderer& m_renderer;

private:
    Metrics& m_metrics;
};

} // namespace textond::app
