// Abandoning work (render/cancel.h): a render whose client left or whose deadline
// passed stops between blocks and answers ErrorCode::cancelled; one that is never told to stop
// gives the same bits as one without a Cancel.
#include "render/cancel.h"
#include "render/cpu_backend.h"
#include "render/surface_eval.h"
#include "tests/render/render_fixtures.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>

namespace textond::test {
namespace {

using render::Cancel;
using render::CpuBackend;
using render::NoiseRequest;
using Clock = std::chrono::steady_clock;

NoiseRequest window(int side, int level = 0) {
    NoiseRequest q;
    q.seed = 7;
    q.level = level;
    q.x0 = -100;
    q.y0 = 33;
    q.width = q.height = side;
    return q;
}

bool same_bits(const core::Image& a, const core::Image& b) {
    return a.data.size() == b.data.size() &&
           std::memcmp(a.data.data(), b.data.data(), a.data.size() * sizeof(float)) == 0;
}

core::MixField ramp() {
    core::MixField f;
    f.kind = core::MixField::Kind::ramp;
    f.x0 = 0;
    f.dx = 1;
    f.dy = 0;
    f.width = 512;
    return f;
}

TEST(Cancel, ACancelThatNeverFiresChangesNoBit) {
    const auto tex = analysed_texton("etr_sand01.png", 32);
    CpuBackend cpu(2, 64);
    const Cancel never(Clock::now() + std::chrono::hours(1), [] { return false; });
    for (int level : {0, tex->limit_level()}) { // the exact sum and the limit model
        NoiseRequest q = window(200, level);
        auto plain = cpu.render(*tex, q);
        q.cancel = &never;
        auto with = cpu.render(*tex, q);
        ASSERT_TRUE(plain.ok() && with.ok()) << level;
        EXPECT_TRUE(same_bits(plain.value(), with.value())) << "level " << level;
    }
    EXPECT_FALSE(never.stop());
}

TEST(Cancel, APassedDeadlineStopsEveryPath) {
    const auto tex = analysed_texton("etr_sand01.png", 32);
    const auto mix = analysed_mix("etr_sand01.png", "etr_pebbles04.png", 32, 3, ramp());
    CpuBackend cpu(2, 64);
    const Cancel late(Clock::now() - std::chrono::seconds(1), {});
    for (int level : {0, tex->limit_level()}) {
        NoiseRequest q = window(256, level);
        q.cancel = &late;
        render::RenderStats stats;
        auto r = cpu.render(*tex, q, &stats);
        ASSERT_FALSE(r.ok()) << level;
        EXPECT_EQ(r.error().code, ErrorCode::cancelled);
        if (level == 0) {
            EXPECT_EQ(stats.evaluations, 0u) << "no block ran";
        }
        auto m = cpu.render_mix(*mix, q);
        ASSERT_FALSE(m.ok()) << level;
        EXPECT_EQ(m.error().code, ErrorCode::cancelled);
    }
    EXPECT_TRUE(late.deadline_passed());

    render::SurfaceRequest sr;
    sr.cancel = &late;
    const std::vector<float> points = {0, 0, 0, 1, 2, 3}, normals = {0, 0, 1, 1, 0, 0};
    auto s = render::evaluate_surface(tex->texton(), sr, points, normals, 1);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.error().code, ErrorCode::cancelled);

    render::Mesh quad;
    quad.positions = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
    quad.triangles = {0, 1, 2, 0, 2, 3};
    auto p = render::render_mesh_preview(tex->texton(), sr, quad, render::Camera{}, 64, 64, 1);
    ASSERT_FALSE(p.ok());
    EXPECT_EQ(p.error().code, ErrorCode::cancelled);
    sr.cancel = nullptr;
    EXPECT_TRUE(
        render::render_mesh_preview(tex->texton(), sr, quad, render::Camera{}, 64, 64, 1).ok());
}

// The client leaves part-way: the render stops with part of its work done, not at its end.
TEST(Cancel, AClientThatLeavesStopsTheRenderPartWay) {
    const auto tex = analysed_texton("etr_sand01.png", 32);
    CpuBackend cpu(1, 32);
    NoiseRequest q = window(1024);
    render::RenderStats full;
    ASSERT_TRUE(cpu.render(*tex, q, &full).ok());

    std::atomic<int> polls{0};
    // Polled at every block (one thread): the client is gone at the fifth of 1024 blocks.
    const Cancel leaves(
        Clock::now() + std::chrono::hours(1), [&] { return ++polls >= 5; }, Clock::duration{0});
    q.cancel = &leaves;
    render::RenderStats part;
    auto r = cpu.render(*tex, q, &part);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::cancelled);
    EXPECT_FALSE(leaves.deadline_passed());
    EXPECT_EQ(polls.load(), 5) << "stop() sticks once the client has gone";
    EXPECT_GT(part.evaluations, 0u);
    EXPECT_LT(part.evaluations, full.evaluations / 100); // 4 blocks of 1024
}

} // namespace
} // namespace textond::test
