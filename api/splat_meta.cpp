#include "api/splat_meta.h"

#include <cmath>

namespace textond::api {

namespace {

nlohmann::json band_json(const core::SplatBand& b) {
    return {std::isinf(b.lo) ? nlohmann::json(nullptr) : nlohmann::json(b.lo),
            std::isinf(b.hi) ? nlohmann::json(nullptr) : nlohmann::json(b.hi)};
}

core::SplatBand band_from(const nlohmann::json& j) {
    core::SplatBand b;
    if (!j.at(0).is_null()) b.lo = j.at(0).get<double>();
    if (!j.at(1).is_null()) b.hi = j.at(1).get<double>();
    return b;
}

} // namespace

void to_json(nlohmann::json& j, const SplatMeta& m) {
    j = nlohmann::json{{"id", m.id},
                       {"version", m.version},
                       {"textons", m.textons},
                       {"layers", m.textons.size()},
                       {"channels", m.channels},
                       {"weights", m.weights}};
    if (!m.created.empty()) j["created"] = m.created;
}

void from_json(const nlohmann::json& j, SplatMeta& m) {
    j.at("id").get_to(m.id);
    j.at("version").get_to(m.version);
    j.at("textons").get_to(m.textons);
    j.at("channels").get_to(m.channels);
    m.weights = j.at("weights");
    m.created = j.value("created", std::string());
}

nlohmann::json splat_weights_json(const core::SplatWeights& w, const std::string& image_sha256,
                                  const std::string& height_id) {
    if (w.kind == core::SplatWeights::Kind::image) {
        const core::SplatImage& s = w.image;
        return {{"kind", "image"},
                {"x0", s.x0},
                {"y0", s.y0},
                {"scale", s.scale},
                {"width", s.weights.width},
                {"height", s.weights.height},
                {"channels", s.weights.channels},
                {"sha256", image_sha256}};
    }
    const core::SplatRules& r = w.rules;
    nlohmann::json layers = nlohmann::json::array();
    for (const core::SplatRule& l : r.layers)
        layers.push_back({{"height", band_json(l.height)}, {"slope", band_json(l.slope)}});
    return {{"kind", "rules"},
            {"height", height_id},
            {"strength", r.strength},
            {"height_soft", r.height_soft},
            {"slope_soft", r.slope_soft},
            {"layers", layers}};
}

core::SplatWeights splat_weights_from_json(const nlohmann::json& j, std::string& height_id) {
    core::SplatWeights w;
    if (j.at("kind") == "image") {
        w.kind = core::SplatWeights::Kind::image;
        w.image.x0 = j.at("x0").get<double>();
        w.image.y0 = j.at("y0").get<double>();
        w.image.scale = j.at("scale").get<double>();
        height_id.clear();
        return w;
    }
    w.kind = core::SplatWeights::Kind::rules;
    height_id = j.at("height").get<std::string>();
    w.rules.strength = j.at("strength").get<double>();
    w.rules.height_soft = j.at("height_soft").get<double>();
    w.rules.slope_soft = j.at("slope_soft").get<double>();
    for (const auto& l : j.at("layers"))
        w.rules.layers.push_back({band_from(l.at("height")), band_from(l.at("slope"))});
    return w;
}

} // namespace textond::api
