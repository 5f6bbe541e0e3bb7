#include "api/texton_meta.h"

#include <cstdio>
#include <ctime>

namespace textond::api {

std::string rfc3339_now() {
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

core::AnalysisParams TextonMeta::params() const {
    core::AnalysisParams p;
    p.size = size;
    p.order = order;
    p.iterations = iterations;
    p.seed = seed;
    p.periodic = periodic;
    return p;
}

std::string TextonMeta::kind() const {
    if (shape_score) return core::to_string(core::shape_kind(*shape_score));
    if (!phase_coherence) return "";
    return core::to_string(core::texture_kind(*phase_coherence));
}

std::string TextonMeta::verdict() const {
    const std::string k = kind();
    if (k.empty()) return "not measured (analysed by an older server)";
    const bool missed = rme > core::kMissedModelRme;
    char rme_text[96];
    std::snprintf(rme_text, sizeof rme_text, "the texton misses its model (RME %.4f, above %.4f)",
                  rme, core::kMissedModelRme);
    if (k == "macro")
        return std::string("macro-texture: expect the noise to lose its shapes (outlines, edges, "
                           "repeated motifs)") +
               (missed ? std::string("; ") + rme_text : "");
    if (k == "borderline")
        return missed ? std::string("borderline: some shapes, edges or repeated motifs may soften "
                                    "or fade, and ") +
                            rme_text
                      : "borderline: the noise keeps the overall look, but some shapes, edges or "
                        "repeated motifs may soften or fade";
    if (missed)
        return std::string("micro-texture, but ") + rme_text +
               ": expect the noise to look unlike the photo";
    return "micro-texture: the noise keeps its look";
}

nlohmann::json canonical_params(const core::AnalysisParams& p) {
    // threads is deliberately absent: it never changes the result.
    return {{"size", p.size},
            {"order", p.order},
            {"iterations", p.iterations},
            {"seed", p.seed},
            {"periodic", p.periodic}};
}

nlohmann::json file_meta_json(const TextonMeta& m) {
    nlohmann::json j{
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
        {"coefficients_sha256", m.coefficients_sha256},
    };
    j["marginals"] = m.exemplar_marginals ? std::vector<std::string>{"gaussian", "exemplar"}
                                          : std::vector<std::string>{"gaussian"};
    if (!m.maps.empty()) {
        nlohmann::json maps = nlohmann::json::array();
        for (const MapMeta& mm : m.maps)
            maps.push_back({{"name", mm.name},
                            {"first", mm.first},
                            {"channels", mm.channels},
                            {"bits", mm.bits},
                            {"range", mm.range},
                            {"rme", mm.rme}});
        j["maps"] = maps;
    }
    if (m.phase_coherence && m.sharpness_index) {
        j["phase_coherence"] = *m.phase_coherence;
        j["sharpness_index"] = *m.sharpness_index;
    }
    if (m.shape_score) j["shape_score"] = *m.shape_score;
    if (!m.kind().empty()) j["kind"] = m.kind();
    return j;
}

nlohmann::json provenance_json(const TextonMeta& m) {
    nlohmann::json j = nlohmann::json::object();
    if (m.timings) {
        const core::AnalysisTimings& t = *m.timings;
        j["timings_ms"] = {{"periodic", t.periodic_ms},
                           {"model", t.model_ms},
                           {"projections", t.projections_ms},
                           {"correction", t.correction_ms},
                           {"rme", t.rme_ms},
                           {"coherence", t.coherence_ms},
                           {"shape", t.shape_ms},
                           {"marginals", t.marginals_ms},
                           {"total", t.total_ms}};
    }
    if (!m.created.empty()) j["created"] = m.created;
    return j;
}

void read_provenance(const nlohmann::json& j, TextonMeta& m) {
    if (const auto it = j.find("timings_ms"); it != j.end()) {
        core::AnalysisTimings t;
        it->at("periodic").get_to(t.periodic_ms);
        it->at("model").get_to(t.model_ms);
        it->at("projections").get_to(t.projections_ms);
        it->at("correction").get_to(t.correction_ms);
        it->at("rme").get_to(t.rme_ms);
        it->at("total").get_to(t.total_ms);
        // Absent from provenance written before the verdict and the marginals were computed.
        t.coherence_ms = it->value("coherence", 0.0);
        t.shape_ms = it->value("shape", 0.0);
        t.marginals_ms = it->value("marginals", 0.0);
        m.timings = t;
    }
    if (const auto it = j.find("created"); it != j.end()) it->get_to(m.created);
}

void to_json(nlohmann::json& j, const TextonMeta& m) {
    j = file_meta_json(m);
    j.update(provenance_json(m));
}

void from_json(const nlohmann::json& j, TextonMeta& m) {
    j.at("id").get_to(m.id);
    j.at("version").get_to(m.version);
    j.at("exemplar").at("width").get_to(m.exemplar_width);
    j.at("exemplar").at("height").get_to(m.exemplar_height);
    j.at("channels").get_to(m.channels);
    if (m.channels < 1 || m.channels > core::kMaxChannels)
        throw nlohmann::json::other_error::create(501, "channels out of range", &j);
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
    j.at("coefficients_sha256").get_to(m.coefficients_sha256);
    m.phase_coherence.reset();
    m.sharpness_index.reset();
    m.shape_score.reset();
    if (const auto it = j.find("shape_score"); it != j.end()) m.shape_score = it->get<double>();
    m.exemplar_marginals = false;
    if (const auto it = j.find("marginals"); it != j.end())
        for (const auto& v : *it) m.exemplar_marginals = m.exemplar_marginals || v == "exemplar";
    if (j.contains("phase_coherence") && j.contains("sharpness_index")) {
        m.phase_coherence = j.at("phase_coherence").get<double>();
        m.sharpness_index = j.at("sharpness_index").get<double>();
    }
    m.maps.clear();
    if (const auto it = j.find("maps"); it != j.end())
        for (const auto& v : *it) {
            MapMeta mm;
            v.at("name").get_to(mm.name);
            v.at("first").get_to(mm.first);
            v.at("channels").get_to(mm.channels);
            v.at("bits").get_to(mm.bits);
            v.at("range").get_to(mm.range);
            v.at("rme").get_to(mm.rme);
            m.maps.push_back(std::move(mm));
        }
    m.timings.reset();
    m.created.clear();
    read_provenance(j, m);
}

} // namespace textond::api
