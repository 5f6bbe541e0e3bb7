// The GLSL noise (OSMesa everywhere, EGL where a GPU or Mesa's EGL exists) against the spec's
// vectors and against the CPU backend.
#include "core/grid_poisson.h"
#include "core/noise_hash.h"

#include "render/cpu_backend.h"
#include "render/egl_backend.h"
#include "render/osmesa_backend.h"
#include "tests/render/noise_vectors.h"
#include "tests/render/render_fixtures.h"
#include <functional>

#include <gtest/gtest.h>

#include <cmath>

namespace textond::test {
namespace {

using render::GlBackend;

std::shared_ptr<GlBackend> osmesa() {
    static auto b = render::make_osmesa_backend();
    return b.ok() ? b.value() : nullptr;
}

// EGL on a real GPU: only where one exists (the device machine); skipped elsewhere.
std::shared_ptr<GlBackend> egl_gpu() {
    static auto b = render::make_egl_backend(false);
    return b.ok() ? b.value() : nullptr;
}

// EGL's code path on whatever renderer Mesa offers (llvmpipe without a GPU).
std::shared_ptr<GlBackend> egl_any() {
    static auto b = render::make_egl_backend(true);
    return b.ok() ? b.value() : nullptr;
}

std::vector<std::uint32_t> words(std::initializer_list<std::uint64_t> v) {
    std::vector<std::uint32_t> q(8, 0);
    std::size_t i = 0;
    for (auto x : v) q[i++] = static_cast<std::uint32_t>(x);
    return q;
}

void check_probe(GlBackend& gl) {
    const auto& doc = noise_vectors();
    std::vector<std::uint32_t> queries;
    std::vector<std::function<void(const std::uint32_t*)>> checks;
    auto add = [&](std::vector<std::uint32_t> q, std::function<void(const std::uint32_t*)> f) {
        queries.insert(queries.end(), q.begin(), q.end());
        checks.push_back(std::move(f));
    };
    for (const auto& v : doc["mix32"])
        add(words({0, v[0].get<std::uint32_t>()}),
            [v](const std::uint32_t* o) { EXPECT_EQ(o[0], v[1].get<std::uint32_t>()); });
    for (const auto& v : doc["cell_key"]) {
        const auto s = v[0].get<std::uint64_t>();
        const auto cx = static_cast<std::uint64_t>(v[1].get<std::int64_t>());
        const auto cy = static_cast<std::uint64_t>(v[2].get<std::int64_t>());
        add(words({1, s & 0xffffffffu, s >> 32, cx & 0xffffffffu, cx >> 32, cy & 0xffffffffu,
                   cy >> 32}),
            [v](const std::uint32_t* o) {
                EXPECT_EQ(o[0], v[3].get<std::uint32_t>()) << v.dump();
            });
    }
    for (const auto& v : doc["pixel_key"]) {
        const auto s = v[0].get<std::uint64_t>();
        const auto px = static_cast<std::uint64_t>(v[2].get<std::int64_t>());
        const auto py = static_cast<std::uint64_t>(v[3].get<std::int64_t>());
        add(words({4, s & 0xffffffffu, s >> 32, static_cast<std::uint32_t>(v[1].get<int>()),
                   px & 0xffffffffu, px >> 32, py & 0xffffffffu, py >> 32}),
            [v](const std::uint32_t* o) {
                EXPECT_EQ(o[0], v[4].get<std::uint32_t>()) << v.dump();
            });
    }
    for (const auto& v : doc["stream"])
        add(words({2, v[0].get<std::uint32_t>()}), [v](const std::uint32_t* o) {
            for (std::size_t k = 0; k < 8; ++k) EXPECT_EQ(o[k], v[1][k].get<std::uint32_t>());
        });
    auto r = gl.probe(queries, {});
    ASSERT_TRUE(r.ok()) << r.error().message;
    for (std::size_t i = 0; i < checks.size(); ++i) checks[i](r.value().data() + 64 * i);

    // Cell points need the threshold table of their (r, MNI): one probe run per case.
    for (const auto& v : doc["cell_points"]) {
        std::array<std::int64_t, 2> period{0, 0};
        if (!v["period"].is_null()) period = v["period"].get<std::array<std::int64_t, 2>>();
        const core::noise::GridPoisson g(v["r"].get<int>(), v["mni"].get<double>(), period);
        std::int64_t cx = v["cx"].get<std::int64_t>(), cy = v["cy"].get<std::int64_t>();
        if (period[0] > 0) {
            cx = core::noise::floor_mod(cx, period[0]);
            cy = core::noise::floor_mod(cy, period[1]);
        }
        const std::uint32_t key = core::noise::cell_key(v["seed"].get<std::uint64_t>(), cx, cy);
        auto p = gl.probe(words({3, key, static_cast<std::uint64_t>(g.a)}), g.thresholds);
        ASSERT_TRUE(p.ok());
        const std::uint32_t* o = p.value().data();
        ASSERT_EQ(o[0], v["points"].size()) << v.dump();
        const std::int64_t ox = v["cx"].get<std::int64_t>() * g.a,
                           oy = v["cy"].get<std::int64_t>() * g.a;
        for (std::size_t k = 0; k < std::min<std::size_t>(12, v["points"].size()); ++k) {
            const auto& e = v["points"][k];
            EXPECT_EQ(ox + o[1 + k * 5], e[0].get<std::int64_t>());
            EXPECT_EQ(o[2 + k * 5], e[1].get<std::uint32_t>());
            EXPECT_EQ(oy + o[3 + k * 5], e[2].get<std::int64_t>());
            EXPECT_EQ(o[4 + k * 5], e[3].get<std::uint32_t>());
            EXPECT_EQ(o[5 + k * 5] == 0 ? 1 : -1, e[4].get<int>());
        }
    }
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

TEST(OsmesaBackend, SpecVectors) {
    auto gl = osmesa();
    if (!gl) GTEST_SKIP() << render::make_osmesa_backend().error().message;
    check_probe(*gl);
}

TEST(OsmesaBackend, FieldVectors) {
    auto gl = osmesa();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    check_field_vectors(*gl);
}

TEST(EglBackend, GpuSpecVectorsAndField) {
    auto gl = egl_gpu();
    if (!gl) GTEST_SKIP() << "no GPU: " << render::make_egl_backend(false).error().message;
    EXPECT_FALSE(gl->software()) << gl->renderer();
    check_probe(*gl);
    check_field_vectors(*gl);
}

} // namespace
} // namespace textond::test
