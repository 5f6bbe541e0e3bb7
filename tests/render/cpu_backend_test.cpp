// The CPU backend: one function, many windows (design invariants 1 and 3).
#include "render/cpu_backend.h"
#include "render/image_buffers.h"
#include "tests/render/render_fixtures.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

namespace textond::test {
namespace {

using render::CpuBackend;
using render::NoiseRequest;

core::Image render_ok(render::Backend& b, const render::PreparedTexton& t, const NoiseRequest& q,
                      render::RenderStats* stats = nullptr) {
    auto r = b.render(t, q, stats);
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
    return r.ok() ? std::move(r.value()) : core::Image(q.width, q.height, t.channels());
}

bool same_bits(const core::Image& a, const core::Image& b) {
    return a.width == b.width && a.height == b.height && a.channels == b.channels &&
           std::memcmp(a.data.data(), b.data.data(), a.data.size() * sizeof(float)) == 0;
}

struct StitchCase {
    int level;
    std::int64_t x0, y0;
};

class Stitching : public ::testing::TestWithParam<StitchCase> {};

// A 2x2 block of 256x256 tiles equals the 512x512 region rendered at once, bit for bit.
TEST_P(Stitching, TwoByTwoTilesEqualTheRegion) {
    const auto tex = analysed_texton("etr_sand01.png", 64);
    CpuBackend cpu(2, 96); // a block size that does not divide the tiles: blocks straddle them
    const StitchCase c = GetParam();
    NoiseRequest q;
    q.seed = 42;
    q.level = c.level;
    q.x0 = c.x0;
    q.y0 = c.y0;
    q.width = q.height = 512;
    EXPECT_EQ(
        first_tile_off_the_region([&](const NoiseRequest& r) { return cpu.render(*tex, r); }, q),
        -1);
}

// Renders reuse recycled buffers without zeroing them (render/image_buffers.h): every pixel must
// be written. Buffers full of NaN, of the same size and larger, change no bit.
TEST(ImageBuffers, ARecycledBufferChangesNoBit) {
    const auto tex = analysed_texton("etr_sand01.png", 64);
    CpuBackend cpu(2, 96);
    NoiseRequest q;
    q.seed = 9;
    q.x0 = -77;
    q.width = 200;
    q.height = 120;
    const core::Image fresh = render_ok(cpu, *tex, q);
    for (int side : {200, 400}) {
        core::Image garbage(side, 120, 3, std::numeric_limits<float>::quiet_NaN());
        render::recycle_image(std::move(garbage));
        EXPECT_TRUE(same_bits(render_ok(cpu, *tex, q), fresh)) << side;
    }
    // Too large to keep: dropped, and rendering still works.
    render::recycle_image(core::Image(2048, 1024, 3));
    EXPECT_TRUE(same_bits(render_ok(cpu, *tex, q), fresh));
}

const std::int64_t kFar = std::int64_t{1} << 40;
INSTANTIATE_TEST_SUITE_P(Levels, Stitching,
                         ::testing::Values(StitchCase{0, 0, 0}, StitchCase{2, 0, 0},
                                           StitchCase{-1, 0, 0}, StitchCase{0, kFar, -kFar},
                                           StitchCase{2, kFar >> 2, -(kFar >> 2)},
                                           StitchCase{-1, -kFar, kFar}, StitchCase{0, -300, -77},
                                           StitchCase{7, 5, -9}));

TEST(CpuBackend, SameBitsForAnyThreadCountAndBlockSize) {
    const auto tex = analysed_texton("etr_sand01.png", 64);
    NoiseRequest q;
    q.seed = 7;
    q.x0 = -1000;
    q.y0 = 333;
    q.width = 300;
    q.height = 200;
    CpuBackend one(1, 128);
    const core::Image ref = render_ok(one, *tex, q);
    for (int threads : {2, 3})
        for (int block : {32, 100, 512}) {
            CpuBackend b(threads, block);
            EXPECT_TRUE(same_bits(render_ok(b, *tex, q), ref)) << threads << " " << block;
        }
    EXPECT_TRUE(same_bits(render_ok(one, *tex, q), ref)) << "same request, same bytes";
}

double correlation(const core::Image& a, const core::Image& b) {
    double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    const double n = static_cast<double>(a.data.size());
    for (std::size_t i = 0; i < a.data.size(); ++i) {
        sa += a.data[i];
        sb += b.data[i];
        saa += static_cast<double>(a.data[i]) * a.data[i];
        sbb += static_cast<double>(b.data[i]) * b.data[i];
        sab += static_cast<double>(a.data[i]) * b.data[i];
    }
    const double ca = saa / n - (sa / n) * (sa / n), cb = sbb / n - (sb / n) * (sb / n);
    return (sab / n - (sa / n) * (sb / n)) / std::sqrt(ca * cb);
}

// Seeds decorrelate, including the authors' bad pair (s, s + 1024) and seeds that differ only in
// their high 32 bits; a window and a shifted one do not repeat (no period of 1024 cells).
TEST(CpuBackend, SeedsDecorrelate) {
    const auto tex = analysed_texton("skimage_gravel.png", 32);
    CpuBackend cpu;
    NoiseRequest q;
    q.width = q.height = 256;
    // 256^2 pixels with correlation length ~r: about (256/32)^2 = 64 independent cells, so the
    // sample correlation of independent fields has a standard deviation near 1/8.
    auto at = [&](std::uint64_t seed, std::int64_t x0) {
        NoiseRequest r = q;
        r.seed = seed;
        r.x0 = x0;
        return render_ok(cpu, *tex, r);
    };
    const core::Image base = at(5, 0);
    EXPECT_NEAR(correlation(base, at(5, 0)), 1.0, 1e-12);
    const double bound = 4.0 / 8.0;
    EXPECT_LT(std::fabs(correlation(base, at(6, 0))), bound);
    EXPECT_LT(std::fabs(correlation(base, at(5 + 1024, 0))), bound);
    EXPECT_LT(std::fabs(correlation(base, at(5 + (std::uint64_t{1} << 32), 0))), bound);
    const int a = tex->cell_size();
    EXPECT_LT(std::fabs(correlation(base, at(5, 1024 * a))), bound);
    // The authors' seed defect: seed s + 1024 was the noise of s shifted by 1024 cells.
    EXPECT_LT(std::fabs(correlation(base, at(5 + 1024, -1024 * a))), bound);
}

TEST(CpuBackend, TileableWrapsExactly) {
    const auto tex = analysed_texton("etr_sand01.png", 32);
    CpuBackend cpu;
    const int a = tex->cell_size(); // 20 texels
    for (int level : {0, -1, 1}) {
        NoiseRequest q;
        q.seed = 3;
        q.level = level;
        q.period = {5, 3};
        const int px = static_cast<int>(level >= 0 ? 5 * a >> level : 5 * a << -level);
        const int py = static_cast<int>(level >= 0 ? 3 * a >> level : 3 * a << -level);
        q.x0 = -px; // straddle the origin: negative cells wrap too
        q.y0 = -py;
        q.width = 3 * px;
        q.height = 2 * py;
        const core::Image img = render_ok(cpu, *tex, q);
        // Period (px, py): the right edge continues into the left one and so on.
        EXPECT_TRUE(same_bits(window(img, 0, 0, px, py), window(img, px, 0, px, py))) << level;
        EXPECT_TRUE(same_bits(window(img, 0, 0, px, py), window(img, 2 * px, py, px, py))) << level;
        EXPECT_TRUE(same_bits(window(img, 0, 0, px, py), window(img, px, py, px, py))) << level;
        // Not trivially periodic within the period: the wrapped texture is not a smaller tile.
        EXPECT_FALSE(same_bits(window(img, 0, 0, px / 2, py), window(img, px / 2, 0, px / 2, py)));
    }
    NoiseRequest bad;
    bad.period = {4, 4};
    bad.level = tex->limit_level();
    EXPECT_TRUE(tex->check(bad).has_value());
}

// The one place a request's rules live (backends trust what passes it: backend.h).
TEST(PreparedTexton, CheckRefusesBadRequestsWithClearErrors) {
    const auto tex = analysed_texton("etr_sand01.png", 32);
    auto fails = [&](NoiseRequest q, const char* needle) {
        auto err = tex->check(q);
        ASSERT_TRUE(err.has_value());
        EXPECT_EQ(err->code, ErrorCode::invalid_argument);
        EXPECT_NE(err->message.find(needle), std::string::npos) << err->message;
    };
    NoiseRequest q;
    q.mni = 0.5;
    fails(q, "mni");
    q = {};
    q.mni = std::nan("");
    fails(q, "mni");
    q = {};
    q.level = 25;
    fails(q, "level");
    q = {};
    q.level = -5;
    fails(q, "level");
    q = {};
    q.width = 0;
    fails(q, "window");
    q = {};
    q.x0 = std::numeric_limits<std::int64_t>::max() - 10;
    fails(q, "plane");
    q = {};
    q.y0 = std::numeric_limits<std::int64_t>::min();
    fails(q, "plane");
    q = {};
    q.level = 20;
    q.x0 = std::int64_t{1} << 50; // 2^70 texels
    fails(q, "plane");
}

} // namespace
} // namespace textond::test
