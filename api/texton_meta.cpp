#include "api/texton_meta.h"

namespace textond::api {

core::AnalysisParams TextonMeta::params() const {
    core::AnalysisParams p;
    p.size = size;
    p.order = order;
    p.iterations = iterations;
    p.seed = seed;
    p.periodic = periodic;
    return p;
}

nlohmann::json canonical_params(const core::AnalysisParams& p) {
    // threads is deliberately absent: it never changes the result.
    return {{"size", p.size},
            {"order", p.order},
            {"iterations", p.iterations},
            {"seed", p.seed},
            {"periodic", p.periodic}};
}

void to_json(nlohmann::json& j, const TextonMeta& m) {
    j = nlohmann::json{
        {"id", m.id},
        {"version", m.version},
        {"exemplar", {{"width", m.exemplar_width}, {"height", m.exemplar_height}}},
        {"channels", m.channels},
        {"mean", std::vector<double>(m.mean.begin(), m.mean.begin() + m.channels)},
        {"size", m.size},
        {"order", m.order},
        {"iterations", m.iterations},
        {"seed", m.seed},
        {"periodic", m.periodic},
        {"mni_default", m.mni_default},
        {"rme", m.rme},
        {"rme_uncorrected", m.rme_uncorrected},
        {"timings_ms",
         {{"periodic", m.timings.periodic_ms},
          {"model", m.timings.model_ms},
          {"projections", m.timings.projections_ms},
          {"correction", m.timings.correction_ms},
          {"rme", m.timings.rme_ms},
          {"total", m.timings.total_ms}}},
        {"coefficients_sha256", m.coefficients_sha256},
    };
    if (!m.created.empty()) j["created"] = m.created;
}

void from_json(const nlohmann::json& j, TextonMeta& m) {
    j.at("id").get_to(m.id);
    j.at("version").get_to(m.version);
    j.at("exemplar").at("width").get_to(m.exemplar_width);
    j.at("exemplar").at("height").get_to(m.exemplar_height);
    j.at("channels").get_to(m.channels);
    const auto mean = j.at("mean").get<std::vector<double>>();
    if (static_cast<int>(mean.size()) != m.channels)
        throw nlohmann::json::other_error::create(501, "mean has the wrong length", &j);
    m.mean = {};
    for (std::size_t c = 0; c < mean.size(); ++c) m.mean[c] = mean[c];
    j.at("size").get_to(m.size);
    j.at("order").get_to(m.order);
    j.at("iterations").get_to(m.iterations);
    j.at("seed").get_to(m.seed);
    j.at("periodic").get_to(m.periodic);
    j.at("mni_default").get_to(m.mni_default);
    j.at("rme").get_to(m.rme);
    j.at("rme_uncorrected").get_to(m.rme_uncorrected);
    const auto& t = j.at("timings_ms");
    t.at("periodic").get_to(m.timings.periodic_ms);
    t.at("model").get_to(m.timings.model_ms);
    t.at("projections").get_to(m.timings.projections_ms);
    t.at("correction").get_to(m.timings.correction_ms);
    t.at("rme").get_to(m.timings.rme_ms);
    t.at("total").get_to(m.timings.total_ms);
    j.at("coefficients_sha256").get_to(m.coefficients_sha256);
    m.created = j.value("created", std::string());
}

} // namespace textond::api
