#include "api/mix_meta.h"

namespace textond::api {

core::AnalysisParams MixMeta::params() const {
    core::AnalysisParams p;
    p.size = size;
    p.order = order;
    p.iterations = iterations;
    p.seed = seed;
    p.periodic = periodic;
    return p;
}

void to_json(nlohmann::json& j, const MixMeta& m) {
    j = nlohmann::json{{"id", m.id},       {"version", m.version},   {"u", m.u},
                       {"v", m.v},         {"levels", m.levels},     {"size", m.size},
                       {"order", m.order}, {"channels", m.channels}, {"iterations", m.iterations},
                       {"seed", m.seed},   {"periodic", m.periodic}, {"grid", m.grid},
                       {"means", m.means}, {"rme", m.rme},           {"field", m.field}};
    if (m.analysis_ms) j["analysis_ms"] = *m.analysis_ms;
    if (!m.created.empty()) j["created"] = m.created;
}

void from_json(const nlohmann::json& j, MixMeta& m) {
    j.at("id").get_to(m.id);
    j.at("version").get_to(m.version);
    j.at("u").get_to(m.u);
    j.at("v").get_to(m.v);
    j.at("levels").get_to(m.levels);
    j.at("size").get_to(m.size);
    j.at("order").get_to(m.order);
    j.at("channels").get_to(m.channels);
    j.at("iterations").get_to(m.iterations);
    j.at("seed").get_to(m.seed);
    // Files before `periodic` was kept were all analysed with the default.
    m.periodic = j.value("periodic", true);
    j.at("grid").get_to(m.grid);
    j.at("means").get_to(m.means);
    j.at("rme").get_to(m.rme);
    m.field = j.at("field");
    m.analysis_ms.reset();
    if (const auto it = j.find("analysis_ms"); it != j.end()) m.analysis_ms = it->get<double>();
    m.created = j.value("created", std::string());
}

} // namespace textond::api
