#include "tests/render/render_fixtures.h"

#include "core/material_set.h"
#include "core/texton_analysis.h"
#include "tests/support/test_support.h"

#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <stdexcept>

namespace textond::test {

std::shared_ptr<const render::PreparedTexton> analysed_texton(const std::string& name, int size,
                                                              int order) {
    static std::mutex mutex;
    static std::map<std::string, std::shared_ptr<const render::PreparedTexton>> cache;
    std::lock_guard<std::mutex> lock(mutex);
    const std::string key = name + "/" + std::to_string(size) + "/" + std::to_string(order);
    auto it = cache.find(key);
    if (it != cache.end()) return it->second;
    core::AnalysisParams p;
    p.size = size;
    p.order = order;
    auto r = core::analyze_texton(load_exemplar(name), p);
    if (!r) throw std::runtime_error(r.error().message);
    auto t = render::PreparedTexton::make(r.value().texton);
    if (!t) throw std::runtime_error(t.error().message);
    cache.emplace(key, t.value());
    return t.value();
}

std::shared_ptr<const render::PreparedMix> analysed_mix(const std::string& u, const std::string& v,
                                                        int size, int levels,
                                                        const core::MixField& field) {
    auto pair = core::common_models(load_exemplar(u), load_exemplar(v), true, 0, 0);
    if (!pair) throw std::runtime_error(pair.error().message);
    core::AnalysisParams p;
    p.size = size;
    p.iterations = 30;
    auto mixed = core::mix_levels(pair.value(), p, levels);
    if (!mixed) throw std::runtime_error(mixed.error().message);
    auto m = render::PreparedMix::make(mixed.value().levels, field);
    if (!m) throw std::runtime_error(m.error().message);
    return m.value();
}

std::shared_ptr<const render::PreparedTexton> pebble_set(int size, int order, bool roughness) {
    const core::Image u = load_exemplar("etr_pebbles04.png");
    const int h = roughness ? 4 : 3;
    core::Image stacked(u.width, u.height, h + 1);
    for (std::size_t k = 0; k < u.plane_size(); ++k) {
        for (int c = 0; c < 3; ++c) stacked.plane(c)[k] = u.plane(c)[k];
        if (roughness) stacked.plane(3)[k] = u.plane(0)[k] * u.plane(1)[k];
        stacked.plane(h)[k] = (u.plane(0)[k] + u.plane(1)[k] + u.plane(2)[k]) / 3.0f;
    }
    std::vector<core::TextonMap> maps = {{"albedo", 0, 3}};
    if (roughness) maps.push_back({"roughness", 3, 1});
    maps.push_back({"height", h, 1});
    core::AnalysisParams p;
    p.size = size;
    p.order = order;
    auto r = core::analyze_material_set(stacked, maps, p);
    if (!r) throw std::runtime_error(r.error().message);
    auto t = render::PreparedTexton::make(r.value().result.texton);
    if (!t) throw std::runtime_error(t.error().message);
    return t.value();
}

int first_tile_off_the_region(const RenderFn& render, const render::NoiseRequest& q) {
    auto whole = render(q);
    if (!whole) return -2;
    const int w = q.width / 2, h = q.height / 2;
    for (int t = 0; t < 4; ++t) {
        render::NoiseRequest tile = q;
        tile.x0 = q.x0 + w * (t % 2);
        tile.y0 = q.y0 + h * (t / 2);
        tile.width = w;
        tile.height = h;
        auto part = render(tile);
        if (!part) return -2;
        for (int c = 0; c < whole.value().channels; ++c)
            for (int y = 0; y < h; ++y)
                if (std::memcmp(&part.value().at(c, 0, y),
                                &whole.value().at(c, w * (t % 2), h * (t / 2) + y),
                                static_cast<std::size_t>(w) * sizeof(float)) != 0)
                    return t;
    }
    return -1;
}

double field_std(const render::PreparedTexton& t, int c) {
    return std::sqrt(t.covariance()->at(c, c, 0, 0));
}

} // namespace textond::test
