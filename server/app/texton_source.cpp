#include "server/app/texton_source.h"

#include "api/noise_fields.h"
#include "core/periodic_component.h"
#include "core/power_spectrum.h"
#include "render/normal_map.h"
#include "server/io/image_io.h"

#include <algorithm>

namespace textond::app {

namespace {

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

constexpr int kReportSide = 256; // the quality report's windows, at most

} // namespace

Result<core::Image> render_view(render::Renderer& renderer, const PreparedTextonResult& set,
                                const api::MapChoice& map, const render::NoiseRequest& q,
                                render::Renderer::Work work, std::string* used) {
    if (map.encoding) { // the height in floats, then its metres as RGB bytes
        api::MapChoice height = map;
        height.encoding.reset();
        render::NoiseRequest f = q;
        f.precision = render::Precision::f32;
        f.bytes = false;
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
        render::NoiseRequest shaded = q; // lit from floats, never from bytes
        shaded.bytes = false;
        auto colour = renderer.noise(*albedo.value(), shaded, work, used);
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

Result<int> TextonSource::interpolation_order(const std::string& id) const {
    auto found = m_textons.find(id);
    if (!found) return found.error();
    return found.value().order;
}

// Normals take two CPU gradient passes, the lit view a render more; normals are made on the CPU
// whatever the backend (the lit view's albedo is rendered).
Result<ImageSource::WindowCost> TextonSource::cost(const std::string& id,
                                                   const api::MapChoice& map) const {
    auto meta = m_textons.find(id);
    if (!meta) return meta.error();
    const int size = meta.value().size, order = meta.value().order;
    if (map.name == core::kLitMap) return WindowCost{3, 2.0 / 3.0, 3, size, order};
    if (map.name == core::kNormalMap) return WindowCost{2, 1.0, 2, size, order};
    return WindowCost{1, 0.0, 1, size, order};
}

std::optional<Error> TextonSource::tilejson_refusal(const std::string& id,
                                                    const api::NoiseParams& noise) const {
    auto meta = m_textons.find(id);
    if (!meta) return meta.error();
    if (noise.exemplar_marginals && !meta.value().exemplar_marginals)
        return make_error(
            ErrorCode::invalid_argument,
            meta.value().maps.empty()
                ? "marginals=exemplar needs the exemplar's marginals, which this texton does not "
                  "keep (analysed before they were kept); use marginals=gaussian"
                : "marginals=exemplar is for textons of one exemplar: a material set's maps are "
                  "analysed as one joint Gaussian model, without exemplar marginals; use "
                  "marginals=gaussian");
    if (!noise.map.name.empty())
        if (auto view = render::map_view(m_textons.prepared(id), noise.map.name); !view)
            return view.error();
    return std::nullopt;
}

Result<ImageSource::Evaluate> TextonSource::prepare(const std::string& id,
                                                    const render::NoiseRequest& q, Work work,
                                                    const api::MapChoice& map) {
    // An unknown id is render_view's refusal, as is a view the set does not have.
    return Evaluate([this, set = m_textons.prepared(id), q, work, map](std::string* used) {
        return render_view(m_renderer, set, map, q, work, used);
    });
}

Result<std::int64_t> TextonSource::report_work_pixels(const std::string& /*id*/) const {
    return std::int64_t{2} * kReportSide * kReportSide;
}

Result<core::Image> TextonSource::report(const std::string& id, const api::NoiseParams& noise,
                                         const render::Cancel& cancel) {
    auto r = quality(id, noise, cancel);
    if (!r) return r.error();
    return std::move(r.value().png);
}

Result<QualityReport> TextonSource::quality(const std::string& id, const api::NoiseParams& noise,
                                            const render::Cancel& cancel) {
    auto meta = m_textons.find(id);
    if (!meta) return meta.error();
    auto exemplar = m_textons.exemplar_image(id);
    if (!exemplar) return exemplar.error();
    const core::Image& u = exemplar.value();
    const int w = std::min(kReportSide, u.width), h = std::min(kReportSide, u.height);
    render::NoiseRequest q = to_noise_request(0, 0, 0, w, h, noise);
    q.cancel = &cancel;
    auto gaussian = window(id, q, Work::frame, "quality");
    if (!gaussian) return gaussian.error();
    core::Image restored;
    if (meta.value().exemplar_marginals) {
        q.marginals = render::Marginals::exemplar;
        auto r = window(id, q, Work::frame, "quality");
        if (!r) return r.error();
        restored = std::move(r.value());
    }
    return quality_report(meta.value(), centre_crop(u, w, h), gaussian.value(), restored);
}

std::string TextonSource::spectrum_key(const std::string& id, const api::NoiseParams& noise) const {
    return std::string(collection()) + "/spectrum/" + id + "/" +
           api::noise_query(noise, api::kReportRoute) + ".png";
}

// Where the Gaussian model holds the two spectra look alike; for a macro-texture (bricks) the
// exemplar shows peaks the noise cannot have.
Result<core::Image> TextonSource::spectrum(const std::string& id, const api::NoiseParams& noise,
                                           const render::Cancel& cancel) {
    auto exemplar = m_textons.exemplar_image(id);
    if (!exemplar) return exemplar.error();
    const core::Image& u = exemplar.value();
    const int w = std::min(512, u.width), h = std::min(512, u.height);
    render::NoiseRequest q = to_noise_request(0, 0, 0, w, h, noise);
    q.cancel = &cancel;
    auto window_of_noise = window(id, q, Work::frame, "spectrum");
    if (!window_of_noise) return window_of_noise.error();
    return side_by_side(
        core::centred_power_spectrum(core::periodic_component(centre_crop(u, w, h))),
        core::centred_power_spectrum(window_of_noise.value()));
}

} // namespace textond::app
