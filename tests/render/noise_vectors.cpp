#include "tests/render/noise_vectors.h"

#include <gtest/gtest.h>

#include <fstream>
#include <stdexcept>

namespace textond::test {

const nlohmann::json& noise_vectors() {
    static const nlohmann::json doc = [] {
        std::ifstream in(TEXTOND_NOISE_VECTORS);
        if (!in) throw std::runtime_error("cannot open " TEXTOND_NOISE_VECTORS);
        return nlohmann::json::parse(in);
    }();
    return doc;
}

std::shared_ptr<const render::PreparedTexton> vector_texton(int index) {
    const auto& t = noise_vectors()["textons"][static_cast<std::size_t>(index)];
    core::Texton tex;
    tex.size = t["size"].get<int>();
    tex.channels = t["channels"].get<int>();
    tex.order = t["order"].get<int>();
    for (int c = 0; c < tex.channels; ++c)
        tex.mean[static_cast<std::size_t>(c)] =
            t["mean"][static_cast<std::size_t>(c)].get<double>();
    tex.alpha = core::Image(tex.size, tex.size, tex.channels);
    for (int c = 0; c < tex.channels; ++c)
        for (int k = 0; k < tex.size * tex.size; ++k)
            tex.alpha.plane(c)[k] =
                t["alpha"][static_cast<std::size_t>(c)][static_cast<std::size_t>(k)].get<float>();
    auto p = render::PreparedTexton::make(std::move(tex));
    if (!p.ok()) throw std::runtime_error(p.error().message);
    return p.value();
}

void check_field_vectors(render::Backend& b) {
    for (const auto& v : noise_vectors()["field"]) {
        const auto tex = vector_texton(v["texton"].get<int>());
        render::NoiseRequest q;
        q.seed = v["seed"].get<std::uint64_t>();
        q.mni = v["mni"].get<double>();
        q.level = v["level"].get<int>();
        q.x0 = v["x"].get<std::int64_t>();
        q.y0 = v["y"].get<std::int64_t>();
        q.width = q.height = 1;
        auto img = b.render(*tex, q);
        ASSERT_TRUE(img.ok()) << img.error().message;
        for (int c = 0; c < tex->channels(); ++c)
            EXPECT_NEAR(img.value().at(c, 0, 0), v["value"][c].get<double>(), 2e-5) << v.dump();
    }
}

} // namespace textond::test
