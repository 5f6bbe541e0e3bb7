// The GLSL noise (OSMesa everywhere, EGL where a GPU or Mesa's EGL exists) against the spec's
// vectors and against the CPU backend.
#include "core/grid_poisson.h"
#include "core/noise_hash.h"

#include "core/surface_noise.h"
#include "core/triangle_mesh.h"
#include "render/backend_factory.h"
#include "render/cancel.h"
#include "render/cpu_backend.h"
#include "render/gl/egl_backend.h"
#include "render/gl/noise_window.h"
#include "render/gl/osmesa_backend.h"
#include "render/renderer.h"
#include "render/surface_eval.h"
#include "tests/render/noise_vectors.h"
#include "tests/render/render_fixtures.h"
#include "tests/support/test_support.h"
#include <functional>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <thread>
#include <tuple>

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

// CPU and GL evaluate the same points in the same order with the same float operations
// (`precise` in the GLSL); what may differ is the rounding of a few operations (llvmpipe and
// GPUs may still fuse or reorder vector arithmetic, texel fetch paths), each about 1 ulp of the
// accumulator, over ~MNI x 4 terms: far below 1e-5 of the field's std. The limit model draws its
// normals through log, cos and sin, whose GLSL precision is not IEEE: 1e-3 of the std.
void check_against_cpu(render::Backend& gl, int order = 1) {
    const auto tex = analysed_texton("etr_sand01.png", order == 3 ? 32 : 64, order);
    render::CpuBackend cpu;
    struct Case {
        int level;
        std::int64_t x0, y0;
        double mni;
        std::uint64_t seed = 77;
    };
    const std::int64_t far = std::int64_t{1} << 40;
    // Seeds at and above 2^32: the high word must reach the shader (77 and 2^32 + 77 differ).
    const std::uint64_t high = (std::uint64_t{1} << 32) + 77, top = ~std::uint64_t{0} - 5;
    for (const Case& c :
         {Case{0, 0, 0, 30}, Case{0, far, -far, 30}, Case{2, -50, 17, 30}, Case{-1, 9, -4, 5},
          Case{-3, far, far, 30}, Case{0, 3, 3, 1}, Case{3, 100, 100, 200},
          Case{tex->limit_level(), 5, 5, 30}, Case{24, -(far >> 4), far >> 4, 30},
          Case{0, 0, 0, 30, high}, Case{-1, 9, -4, 5, top}, Case{3, 100, 100, 30, high},
          Case{tex->limit_level(), 5, 5, 30, high}}) {
        render::NoiseRequest q;
        q.seed = c.seed;
        q.level = c.level;
        q.x0 = c.x0;
        q.y0 = c.y0;
        q.mni = c.mni;
        q.width = 61;
        q.height = 47;
        auto a = cpu.render(*tex, q);
        auto b = gl.render(*tex, q);
        ASSERT_TRUE(a.ok() && b.ok()) << (b.ok() ? "" : b.error().message);
        const bool limit = c.level >= tex->limit_level();
        for (int ch = 0; ch < 3; ++ch) {
            double worst = 0;
            for (int y = 0; y < q.height; ++y)
                for (int x = 0; x < q.width; ++x)
                    worst = std::max(
                        worst, std::fabs(double(a.value().at(ch, x, y)) - b.value().at(ch, x, y)));
            // Box-averaged levels have a smaller std than level 0; the bound uses level 0's.
            const double tol = (limit ? 1e-3 : 1e-5) * field_std(*tex, ch);
            EXPECT_LE(worst, tol) << gl.name() << " level " << c.level << " x0 " << c.x0 << " seed "
                                  << c.seed << " channel " << ch;
        }
    }
    // Tileable mode too.
    render::NoiseRequest q;
    q.period = {3, 2};
    q.width = 3 * tex->cell_size();
    q.height = 2 * tex->cell_size();
    auto a = cpu.render(*tex, q);
    auto b = gl.render(*tex, q);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_LE(max_abs_diff(a.value(), b.value()), 1e-5 * field_std(*tex, 0));
}

TEST(OsmesaBackend, AgreesWithCpu) {
    auto gl = osmesa();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    check_against_cpu(*gl);
}

// A material set's maps (texton views of the set's channels, driven by the set's Poisson process)
// on a GL backend against the CPU, with the bounds above; at the limit levels, whose model couples
// the maps through the set's normals, the GL backend says unsupported and the Renderer leaves
// them to the CPU (server test MaterialSet.*).
void check_maps_against_cpu(render::Backend& gl) {
    render::CpuBackend cpu;
    for (int order : {1, 3}) {
        const auto set = pebble_set(16, order, true);
        const std::int64_t far = std::int64_t{1} << 40;
        const std::uint64_t high = (std::uint64_t{1} << 32) + 77;
        for (const char* name : {"albedo", "roughness", "height"}) {
            auto view = set->map(name);
            ASSERT_TRUE(view.ok()) << name;
            const auto& map = *view.value();
            for (const auto& [level, x0, seed] :
                 std::vector<std::tuple<int, std::int64_t, std::uint64_t>>{
                     {0, 0, 77}, {0, far, high}, {2, -50, high}, {-1, 9, 77}}) {
                render::NoiseRequest q;
                q.seed = seed;
                q.level = level;
                q.x0 = x0;
                q.y0 = -x0;
                q.width = 41;
                q.height = 23;
                auto a = cpu.render(map, q);
                auto b = gl.render(map, q);
                ASSERT_TRUE(a.ok() && b.ok()) << (b.ok() ? "" : b.error().message);
                ASSERT_EQ(b.value().channels, map.channels());
                for (int ch = 0; ch < map.channels(); ++ch) {
                    double worst = 0;
                    for (int y = 0; y < q.height; ++y)
                        for (int x = 0; x < q.width; ++x)
                            worst = std::max(worst, std::fabs(double(a.value().at(ch, x, y)) -
                                                              b.value().at(ch, x, y)));
                    EXPECT_LE(worst, 1e-5 * field_std(map, ch))
                        << gl.name() << " order " << order << " map " << name << " level " << level
                        << " channel " << ch;
                }
            }
            render::NoiseRequest q;
            q.level = map.limit_level();
            q.width = q.height = 8;
            auto limit = gl.render(map, q);
            ASSERT_FALSE(limit.ok());
            EXPECT_EQ(limit.error().code, ErrorCode::unsupported);
        }
    }
}

TEST(OsmesaBackend, MaterialMapsAgreeWithCpu) {
    auto gl = osmesa();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    check_maps_against_cpu(*gl);
}

TEST(EglBackend, GpuMaterialMapsAgreeWithCpu) {
    auto gl = egl_gpu();
    if (!gl) GTEST_SKIP() << "no GPU";
    check_maps_against_cpu(*gl);
}

// The encoder's rounding of one value to `bits` (server/io/image_io.cpp, interleave).
std::uint32_t rounded(float v, int bits) {
    const float scale = bits == 8 ? 255.0f : 65535.0f;
    return static_cast<std::uint32_t>(std::clamp(v, 0.0f, 1.0f) * scale + 0.5f);
}

// A batch (GlBackend::render_batch): windows of two textons at exact, sampled and limit levels,
// a tileable one, a mix, at every precision, a cancelled one, and floats larger than a pass (so
// the two readback slots are reused): each comes out of the batch bit for bit as it does alone,
// and the quantised ones are the CPU's floats as the encoder rounds them.
void check_batch_against_singles(GlBackend& gl) {
    const auto sand = analysed_texton("etr_sand01.png", 64);
    const auto cork = analysed_texton("mypaint_HR_Cork.png", 32, 3);
    const auto gravel = analysed_texton("skimage_gravel.png", 32); // grey
    core::MixField ramp;
    ramp.dx = 1;
    ramp.width = 60;
    const auto mix = analysed_mix("etr_sand01.png", "etr_pebbles04.png", 32, 5, ramp);
    render::CpuBackend cpu;
    struct Item {
        const render::PreparedTexton* texton;
        const render::PreparedMix* mix;
        render::NoiseRequest q;
    };
    std::vector<Item> items;
    auto add = [&](const render::PreparedTexton& t, const render::PreparedMix* m, int level,
                   std::int64_t x0, std::int64_t y0, int w, int h, render::Precision p,
                   std::uint64_t seed) {
        render::NoiseRequest q;
        q.level = level;
        q.x0 = x0;
        q.y0 = y0;
        q.width = w;
        q.height = h;
        q.precision = p;
        q.seed = seed;
        items.push_back({&t, m, q});
    };
    using P = render::Precision;
    for (int i = 0; i < 6; ++i) // tiles of one texton and level: one dispatch
        add(*sand, nullptr, 0, 64 * i - 100, 64 * (i % 2), 64, 64, P::u8, 5);
    add(*sand, nullptr, 2, -7, 3, 40, 30, P::u8, std::uint64_t{1} << 33);
    add(*sand, nullptr, -2, 11, -9, 50, 20, P::u16, 9);
    add(*cork, nullptr, 0, 1 << 20, -5, 33, 17, P::u8, 1);
    add(*cork, nullptr, -1, 0, 0, 64, 64, P::f32, 1);
    add(*sand, nullptr, sand->limit_level(), 3, 4, 48, 32, P::u8, 2);
    add(mix->level(0), mix.get(), 0, -40, 0, 80, 40, P::u8, 3);
    add(mix->level(0), mix.get(), 1, -20, 0, 40, 40, P::f32, 3);
    // Frames of more than one pass: 1500 x 1000 floats is two on a GPU (2^22 words a pass); a
    // software renderer's passes are 16x smaller, and so are these frames (still several pieces).
    const bool software = gl.pass_words() < (std::size_t{1} << 22);
    add(*sand, nullptr, -3, 0, 0, software ? 375 : 1500, software ? 250 : 1000, P::f32, 4);
    add(*sand, nullptr, -3, 5, 5, software ? 225 : 900, software ? 225 : 900, P::f32, 6);
    items.back().q.period = {0, 0};
    add(*sand, nullptr, 0, 0, 0, 3 * sand->cell_size(), 2 * sand->cell_size(), P::u16, 8);
    items.back().q.period = {3, 2};
    // 8-bit windows taken as bytes (NoiseRequest::bytes), beside the float ones of their passes:
    // grey and RGB, a mix, the limit model, and a frame of several pieces.
    const auto bytes = [&] { items.back().q.bytes = true; };
    add(*sand, nullptr, 0, 64 * 6 - 100, 0, 64, 64, P::u8, 5);
    bytes();
    add(*cork, nullptr, 0, 1 << 20, 40, 33, 17, P::u8, 1);
    bytes();
    add(*gravel, nullptr, 2, -5, 6, 40, 24, P::u8, 7);
    bytes();
    add(*sand, nullptr, sand->limit_level(), -3, 4, 48, 32, P::u8, 2);
    bytes();
    add(mix->level(0), mix.get(), 0, -40, 40, 80, 40, P::u8, 3);
    bytes();
    add(*sand, nullptr, 1, 7, -9, software ? 700 : 2500, software ? 450 : 2000, P::u8, 4);
    bytes();
    render::Cancel gone(render::Cancel::Clock::now() - std::chrono::seconds(1), nullptr);
    add(*sand, nullptr, 0, 0, 0, 64, 64, P::u8, 5);
    items.back().q.cancel = &gone;

    std::vector<GlBackend::Work> works;
    for (const Item& it : items) {
        auto w = gl.prepare(*it.texton, it.mix, it.q);
        ASSERT_TRUE(w.ok()) << w.error().message;
        works.push_back(std::move(w.value()));
    }
    std::vector<GlBackend::Work*> batch;
    for (auto& w : works) batch.push_back(&w);
    gl.render_batch(batch);

    for (std::size_t i = 0; i < items.size(); ++i) {
        const Item& it = items[i];
        auto& got = works[i].image;
        if (it.q.cancel) {
            ASSERT_FALSE(got.ok());
            EXPECT_EQ(got.error().code, ErrorCode::cancelled);
            continue;
        }
        ASSERT_TRUE(got.ok()) << i << ": " << got.error().message;
        auto alone = it.mix ? gl.render_mix(*it.mix, it.q) : gl.render(*it.texton, it.q);
        ASSERT_TRUE(alone.ok()) << alone.error().message;
        ASSERT_EQ(got.value().data.size(), alone.value().data.size());
        EXPECT_EQ(0, std::memcmp(got.value().data.data(), alone.value().data.data(),
                                 got.value().data.size() * sizeof(float)))
            << gl.name() << " window " << i << ": batched differs from alone";
        EXPECT_EQ(got.value().bytes, alone.value().bytes) << gl.name() << " window " << i;
        const core::Image& g = got.value();
        ASSERT_EQ(g.is_bytes(), it.q.bytes) << i;
        ASSERT_EQ(g.is_bytes() ? g.data.size() : g.bytes.size(), 0u) << i;
        const std::size_t values = g.plane_size() * static_cast<std::size_t>(g.channels);
        ASSERT_EQ(g.is_bytes() ? g.bytes.size() : g.data.size(), values) << i;
        EXPECT_GT(works[i].stats.gpu_ms, -1.0);
        const bool exact = it.q.level < it.texton->limit_level();
        if (it.q.precision == P::f32 || (!exact && !it.q.bytes)) continue;
        render::NoiseRequest full = it.q;
        full.precision = P::f32;
        full.bytes = false;
        auto want = it.mix ? cpu.render_mix(*it.mix, full) : cpu.render(*it.texton, full);
        if (!exact) // the limit model is GL's own floats (within float rounding of the CPU's)
            want = gl.render(*it.texton, full);
        ASSERT_TRUE(want.ok());
        const int bits = it.q.precision == P::u8 ? 8 : 16;
        std::size_t differ = 0;
        for (std::size_t k = 0; k < values; ++k) {
            // the bytes interleave the channels; floats are planar
            const std::size_t px = k % g.plane_size(), c = k / g.plane_size();
            const std::uint32_t have =
                g.is_bytes() ? g.bytes[px * g.channels + c] : rounded(g.data[k], bits);
            differ += rounded(want.value().data[k], bits) != have;
        }
        // Bit-identical floats round alike; a mix's float field may move a value by 1e-5 std.
        EXPECT_LE(differ, it.mix ? want.value().data.size() / 1000 : 0u)
            << gl.name() << " window " << i << " at " << bits << " bits";
    }
}

TEST(OsmesaBackend, BatchGivesEachWindowAsAlone) {
    auto gl = osmesa();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    check_batch_against_singles(*gl);
}

// A batch whose listed points would overflow a storage buffer is split (and a window that alone
// overflows one is refused), never read past the buffer's end.
TEST(OsmesaBackend, BatchOverAStorageBufferIsSplit) {
    auto found = render::make_osmesa_backend();
    if (!found) GTEST_SKIP() << "no OSMesa";
    GlBackend& gl = *found.value();
    const auto sand = analysed_texton("etr_sand01.png", 64);
    std::vector<render::NoiseRequest> qs(6);
    for (int i = 0; i < 6; ++i) {
        qs[static_cast<std::size_t>(i)].x0 = 100 * i;
        qs[static_cast<std::size_t>(i)].width = qs[static_cast<std::size_t>(i)].height = 48;
    }
    const auto whole = gl.render_many(*sand, qs);
    auto one = gl.prepare(*sand, nullptr, qs[0]);
    ASSERT_TRUE(one.ok());
    const std::size_t bytes = one.value().window->points.size() * 4;
    gl.limit_storage_block(2 * bytes + bytes / 2); // two windows' points fit, three do not
    const auto split = gl.render_many(*sand, qs);
    for (std::size_t i = 0; i < qs.size(); ++i) {
        ASSERT_TRUE(whole[i].ok() && split[i].ok()) << i;
        EXPECT_EQ(0, std::memcmp(whole[i].value().data.data(), split[i].value().data.data(),
                                 whole[i].value().data.size() * sizeof(float)))
            << "window " << i;
    }
    gl.limit_storage_block(bytes / 2);
    const auto refused = gl.render_many(*sand, {qs[0]});
    ASSERT_FALSE(refused[0].ok());
    EXPECT_EQ(refused[0].error().code, ErrorCode::too_large);
}

// A GPU's kernel (points drawn by each workgroup into shared memory) against llvmpipe's (points
// listed on the host, or regenerated per pixel): the same bits, float and 8-bit, at every exact
// level, order, MNI, far positions, tileable windows and mixes. With mark_overflow, a group whose
// points do not fit writes -1e30, so the windows that fit are shown to come from shared memory,
// and the one that does not is shown to take the per-pixel gather, with the same bits.
void check_shared_kernel(GlBackend& listed, GlBackend& shared) {
    using Kernel = GlBackend::PointKernel;
    listed.set_point_kernel(Kernel::host_listed);
    shared.set_point_kernel(Kernel::shared, true);
    auto same = [](const core::Image& a, const core::Image& b) {
        return a.data.size() == b.data.size() &&
               std::memcmp(a.data.data(), b.data.data(), a.data.size() * sizeof(float)) == 0;
    };
    auto marked = [](const core::Image& a) {
        return std::count(a.data.begin(), a.data.end(), -1e30f) > 0;
    };
    const std::int64_t far = std::int64_t{1} << 40;
    for (int order : {0, 1, 3}) {
        const auto tex = analysed_texton("etr_sand01.png", order == 3 ? 32 : 64, order);
        struct Case {
            int level;
            std::int64_t x0, y0;
            double mni;
            int w, h;
            render::Precision precision;
        };
        for (const Case& c : {Case{0, 0, 0, 30, 61, 47, render::Precision::f32},
                              Case{0, far, -far, 30, 200, 130, render::Precision::u8},
                              Case{1, -50, 17, 5, 64, 64, render::Precision::f32},
                              Case{2, -50, 17, 30, 61, 47, render::Precision::f32},
                              Case{3, 100, -100, 30, 33, 20, render::Precision::u16},
                              Case{-1, 9, -4, 5, 61, 47, render::Precision::f32},
                              Case{-3, far, far, 30, 40, 40, render::Precision::u8},
                              Case{0, 3, 3, 1, 17, 17, render::Precision::f32}}) {
            render::NoiseRequest q;
            q.seed = (std::uint64_t{1} << 32) + 77;
            q.level = c.level;
            q.x0 = c.x0;
            q.y0 = c.y0;
            q.mni = c.mni;
            q.width = c.w;
            q.height = c.h;
            q.precision = c.precision;
            auto a = listed.render(*tex, q);
            auto b = shared.render(*tex, q);
            ASSERT_TRUE(a.ok() && b.ok()) << (b.ok() ? "" : b.error().message);
            EXPECT_FALSE(marked(b.value())) << "order " << order << " level " << c.level;
            EXPECT_TRUE(same(a.value(), b.value())) << "order " << order << " level " << c.level;
        }
        render::NoiseRequest tileable;
        tileable.period = {3, 2};
        tileable.width = 3 * tex->cell_size();
        tileable.height = 2 * tex->cell_size();
        auto a = listed.render(*tex, tileable);
        auto b = shared.render(*tex, tileable);
        ASSERT_TRUE(a.ok() && b.ok());
        EXPECT_TRUE(same(a.value(), b.value())) << "tileable, order " << order;
    }
    // Too many points for shared memory: marked, then with the fallback the same bits.
    const auto sand = analysed_texton("etr_sand01.png", 64);
    render::NoiseRequest heavy;
    heavy.level = 4;
    heavy.mni = 200;
    heavy.width = heavy.height = 20;
    auto a = listed.render(*sand, heavy);
    auto b = shared.render(*sand, heavy);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_TRUE(marked(b.value())) << "level 4 at MNI 200 fit shared memory: pick a heavier case";
    shared.set_point_kernel(Kernel::shared);
    b = shared.render(*sand, heavy);
    ASSERT_TRUE(b.ok());
    EXPECT_TRUE(same(a.value(), b.value())) << "the per-pixel fallback";
    // Mixes: each point's level drawn in the group, as the host lists it.
    core::MixField ramp;
    ramp.x0 = -30;
    ramp.dx = 1;
    ramp.dy = 0.5;
    ramp.width = 90;
    const auto mix = analysed_mix("etr_sand01.png", "etr_pebbles04.png", 32, 7, ramp);
    for (int level : {-1, 0, 2}) {
        render::NoiseRequest q;
        q.seed = 3;
        q.level = level;
        q.x0 = -64;
        q.width = 90;
        q.height = 50;
        auto ma = listed.render_mix(*mix, q);
        auto mb = shared.render_mix(*mix, q);
        ASSERT_TRUE(ma.ok() && mb.ok());
        EXPECT_TRUE(same(ma.value(), mb.value())) << "mix level " << level;
    }
}

TEST(OsmesaBackend, SharedPointKernelGivesTheListedKernelsBits) {
    auto listed = render::make_osmesa_backend();
    auto shared = render::make_osmesa_backend();
    if (!listed || !shared) GTEST_SKIP() << "no OSMesa";
    check_shared_kernel(*listed.value(), *shared.value());
}

TEST(EglBackend, GpuSharedPointKernelGivesTheListedKernelsBits) {
    auto shared = egl_gpu();
    auto listed = render::make_egl_backend(false);
    if (!shared || !listed) GTEST_SKIP() << "no GPU";
    check_shared_kernel(*listed.value(), *shared);
    shared->set_point_kernel(GlBackend::PointKernel::shared); // as made, for the tests after
}

TEST(EglBackend, GpuBatchGivesEachWindowAsAlone) {
    auto gl = egl_gpu();
    if (!gl) GTEST_SKIP() << "no GPU";
    check_batch_against_singles(*gl);
}

// Texture mixes: the level of each point and the mean colour from the field, in float on the GPU
// against double on the CPU. A point whose rho (R - 1) lies within ~1e-6 of a half-integer could
// take the neighbouring level on one of them; with these seeds none does, and the agreement is
// the plain noise's.
void check_mix_against_cpu(render::Backend& gl) {
    core::MixField ramp;
    ramp.x0 = -30;
    ramp.y0 = 10;
    ramp.dx = 1;
    ramp.dy = 0.5;
    ramp.width = 90;
    core::MixField mask;
    mask.kind = core::MixField::Kind::mask;
    mask.mask = core::Image(3, 2, 1);
    mask.mask.at(0, 1, 0) = 0.5f;
    mask.mask.at(0, 2, 0) = 1.0f;
    mask.mask.at(0, 2, 1) = 0.8f;
    mask.x0 = -40;
    mask.scale = 30;
    render::CpuBackend cpu;
    for (const core::MixField& f : {ramp, mask}) {
        const auto mix = analysed_mix("etr_sand01.png", "etr_pebbles04.png", 32, 7, f);
        for (int level : {-1, 0, 2}) {
            render::NoiseRequest q;
            q.seed = 3;
            q.level = level;
            q.x0 = -64 >> std::max(0, level);
            q.y0 = -20;
            q.width = 90;
            q.height = 50;
            auto a = cpu.render_mix(*mix, q);
            auto b = gl.render_mix(*mix, q);
            ASSERT_TRUE(a.ok() && b.ok()) << (b.ok() ? "" : b.error().message);
            EXPECT_LE(max_abs_diff(a.value(), b.value()), 1e-5 * field_std(mix->level(0), 1))
                << gl.name() << " level " << level << " field " << static_cast<int>(f.kind);
        }
        render::NoiseRequest limit;
        limit.level = mix->level(0).limit_level();
        EXPECT_EQ(gl.render_mix(*mix, limit).error().code, ErrorCode::unsupported);
    }
}

TEST(OsmesaBackend, TextureMixAgreesWithCpu) {
    auto gl = osmesa();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    check_mix_against_cpu(*gl);
}

TEST(EglBackend, GpuTextureMixAgreesWithCpu) {
    auto gl = egl_gpu();
    if (!gl) GTEST_SKIP() << "no GPU";
    check_mix_against_cpu(*gl);
}

// Cubic B-spline textons: 16 taps per point, tables padded by 3 (NOISE_SPEC.md section 7).
TEST(OsmesaBackend, AgreesWithCpuAtOrders0And3) {
    auto gl = osmesa();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    check_against_cpu(*gl, 0);
    check_against_cpu(*gl, 3);
}

TEST(EglBackend, GpuAgreesWithCpuAtOrders0And3) {
    auto gl = egl_gpu();
    if (!gl) GTEST_SKIP() << "no GPU";
    check_against_cpu(*gl, 0);
    check_against_cpu(*gl, 3);
}

// Surface noise: the compute shader against core/surface_noise.cpp at the same points and seed.
// The CPU works in double, the GPU in float from exact small-integer offsets: the frame and the
// projections of ~30-texel offsets round at 1e-7, which moves each of ~60 impacts by ~3e-6
// texels; measured 1.4e-4 of the field's std at worst, bounded here by 1e-3.
void check_surface_against_cpu(GlBackend& gl) {
    constexpr double kPi = 3.14159265358979323846;
    for (int order : {1, 3}) {
        const auto tex = analysed_texton("etr_sand01.png", 32, order);
        std::vector<double> y;
        std::vector<float> n;
        for (int i = 0; i < 300; ++i) {
            const double z = 1 - 2 * (i + 0.5) / 300, rad = std::sqrt(1 - z * z);
            const double phi = i * kPi * (3 - std::sqrt(5.0));
            const double d[3] = {rad * std::cos(phi), rad * std::sin(phi), z};
            const double centre[3] = {1.0e6, -2.0e6, 3.0e5};
            for (int k = 0; k < 3; ++k) {
                y.push_back(centre[k] + 5000.25 * d[k]);
                n.push_back(static_cast<float>(d[k]));
            }
        }
        n[3 * 299 + 0] = 0; // the frame's singular direction, exactly
        n[3 * 299 + 1] = 0;
        n[3 * 299 + 2] = -1;
        for (std::uint64_t seed : {std::uint64_t{0}, std::uint64_t{1} << 40}) {
            auto got = gl.surface(*tex, seed, 60, y, n);
            ASSERT_TRUE(got.ok()) << got.error().message;
            const core::SurfaceNoise cpu(tex->texton(), 60);
            double worst = 0;
            for (std::size_t i = 0; i < 300; ++i) {
                float want[3];
                core::Vec3 nn = {n[3 * i], n[3 * i + 1], n[3 * i + 2]};
                const double len = std::sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
                for (double& v : nn) v /= len;
                cpu.eval(seed, {y[3 * i], y[3 * i + 1], y[3 * i + 2]}, nn, want);
                for (int c = 0; c < 3; ++c)
                    worst = std::max(worst, std::fabs(double(want[c]) - got.value()[3 * i + c]));
            }
            EXPECT_LT(worst, 1e-3 * field_std(*tex, 1)) << gl.name() << " order " << order;
        }
    }
}

// The mesh preview drawn by OpenGL against the CPU rasteriser: the same coverage but for
// silhouette pixels, and the same colours inside (both sample pixel centres, perspective-correct).
void check_mesh_against_cpu(GlBackend& gl) {
    const auto tex = analysed_texton("etr_sand01.png", 32, 1);
    core::TriangleMesh sphere;
    const int rings = 24, segments = 48;
    const double pi = 3.14159265358979323846;
    for (int i = 0; i <= rings; ++i)
        for (int j = 0; j < segments; ++j) {
            const double th = pi * i / rings, ph = 2 * pi * j / segments;
            for (double v :
                 {std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph)})
                sphere.positions.push_back(static_cast<float>(v));
        }
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            const auto a = static_cast<std::uint32_t>(i * segments + j),
                       b = static_cast<std::uint32_t>(i * segments + (j + 1) % segments);
            for (std::uint32_t v : {a, a + segments, b + segments, a, b + segments, b})
                sphere.triangles.push_back(v);
        }
    core::smooth_normals(sphere);
    render::SurfaceRequest req;
    req.seed = 4;
    render::Camera cam;
    cam.light = {-0.5, 0.6, 0.4}; // not the default: the light must reach the shader
    const int w = 96, h = 80;
    auto cpu = render::render_mesh_preview(tex->texton(), req, sphere, cam, w, h);
    auto view = render::mesh_view(sphere, req, cam, w, h);
    ASSERT_TRUE(cpu.ok() && view.ok());
    auto got = gl.mesh_preview(*tex, req.seed, req.mni, sphere, view.value(), w, h);
    ASSERT_TRUE(got.ok()) << got.error().message;
    int covered = 0, differ = 0, inside = 0;
    double worst = 0, step = 0; // step: the largest colour change between neighbouring pixels
    for (int y = 1; y + 1 < h; ++y)
        for (int x = 1; x + 1 < w; ++x) {
            const bool a = cpu.value().at(3, x, y) > 0.5f, b = got.value().at(3, x, y) > 0.5f;
            covered += a;
            differ += a != b;
            bool interior = a && b;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx)
                    interior = interior && cpu.value().at(3, x + dx, y + dy) > 0.5f;
            if (!interior) continue;
            ++inside;
            for (int c = 0; c < 3; ++c) {
                const double v = cpu.value().at(c, x, y);
                worst = std::max(worst, std::fabs(v - got.value().at(c, x, y)));
                step = std::max({step, std::fabs(v - cpu.value().at(c, x + 1, y)),
                                 std::fabs(v - cpu.value().at(c, x, y + 1))});
            }
        }
    // The error budget. A rasteriser snaps vertices to 2^-b of a pixel (GL_SUBPIXEL_BITS), which
    // moves the barycentrics of a pixel centre, and with them the interpolated surface point, by
    // at most half a snap step in each screen axis: the point sampled is at most 2^-(b+1) pixel
    // (per axis) from the CPU's, so its colour differs by at most 2 x 2^-(b+1) x the largest
    // change between neighbouring pixels (the noise is smooth at the pixel scale: a texton covers
    // many pixels here). Float positions, normals and sums add ~1e-6 (measured 1.4e-6 on
    // llvmpipe), bounded by 1e-5. An H100 (8 bits) measured 3.0e-4.
    const double bound = 2 * std::ldexp(1.0, -(gl.subpixel_bits() + 1)) * step + 1e-5;
    std::printf("%s mesh preview: %d covered pixels, %d differ in coverage, worst colour %.2g, "
                "bound %.2g (%d subpixel bits, neighbour step %.2g)\n",
                gl.name().c_str(), covered, differ, worst, bound, gl.subpixel_bits(), step);
    EXPECT_GT(covered, w * h / 8);
    EXPECT_LT(differ, covered / 50) << gl.name();
    EXPECT_GT(inside, covered / 2);
    EXPECT_LT(worst, bound) << gl.name();
}

TEST(OsmesaBackend, MeshPreviewAgreesWithCpu) {
    auto gl = osmesa();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    check_mesh_against_cpu(*gl);
}

TEST(EglBackend, GpuMeshPreviewAgreesWithCpu) {
    auto gl = egl_gpu();
    if (!gl) GTEST_SKIP() << "no GPU";
    check_mesh_against_cpu(*gl);
}

TEST(OsmesaBackend, SurfaceNoiseAgreesWithCpu) {
    auto gl = osmesa();
    if (!gl) GTEST_SKIP() << "no OSMesa";
    check_surface_against_cpu(*gl);
}

TEST(EglBackend, GpuSurfaceNoiseAgreesWithCpu) {
    auto gl = egl_gpu();
    if (!gl) GTEST_SKIP() << "no GPU";
    check_surface_against_cpu(*gl);
}

TEST(EglBackend, CodePathAgreesWithCpuOnAnyRenderer) {
    auto gl = egl_any();
    if (!gl) GTEST_SKIP() << "no EGL at all: " << render::make_egl_backend(true).error().message;
    check_against_cpu(*gl);
}

TEST(EglBackend, GpuAgreesWithCpu) {
    auto gl = egl_gpu();
    if (!gl) GTEST_SKIP() << "no GPU";
    check_against_cpu(*gl);
}

TEST(BackendFactory, ReportsWhatItPickedAndWhy) {
    auto cpu = render::make_backend(render::BackendKind::cpu);
    ASSERT_TRUE(cpu.ok());
    EXPECT_EQ(cpu.value().backend->name(), "cpu");
    auto automatic = render::make_backend(render::BackendKind::automatic);
    ASSERT_TRUE(automatic.ok());
    EXPECT_NE(automatic.value().reason.find("auto"), std::string::npos);
    if (egl_gpu()) {
        // Measured: two candidates, and each kind of work on the faster of them.
        const auto& c = automatic.value().calibration;
        ASSERT_EQ(c.size(), 2u) << automatic.value().reason;
        const auto [t, f] = render::pick_fastest(c);
        EXPECT_EQ(automatic.value().backend->name(), c[f].backend);
        EXPECT_EQ(automatic.value().tiles->name(), c[t].backend);
    } else {
        EXPECT_EQ(automatic.value().backend->name(), "cpu") << automatic.value().reason;
    }
    EXPECT_FALSE(render::parse_backend_kind("vulkan").ok());
}

// auto never takes a backend that is slower than the CPU, for tiles or for frames, and a tie
// stays on the CPU (entry 0).
TEST(BackendFactory, PicksTheFastestAndNeverOneSlowerThanTheCpu) {
    using C = render::Calibration;
    EXPECT_EQ(render::pick_fastest({C{"cpu", 10, 50}}),
              std::make_pair(std::size_t{0}, std::size_t{0}));
    EXPECT_EQ(render::pick_fastest({C{"cpu", 10, 50}, C{"egl", 5, 80}}),
              std::make_pair(std::size_t{1}, std::size_t{0}));
    EXPECT_EQ(render::pick_fastest({C{"cpu", 10, 50}, C{"egl", 12, 20}}),
              std::make_pair(std::size_t{0}, std::size_t{1}));
    EXPECT_EQ(render::pick_fastest({C{"cpu", 10, 50}, C{"egl", 10, 50}}),
              std::make_pair(std::size_t{0}, std::size_t{0}));
    EXPECT_EQ(render::pick_fastest({C{"cpu", 10, 50}, C{"egl", 1, 1}}),
              std::make_pair(std::size_t{1}, std::size_t{1}));
}

// A backend that renders blank windows slowly and counts how many of its renders overlap.
class OverlapProbe final : public render::Backend {
public:
    std::string name() const override { return "probe"; }
    std::string renderer() const override { return "probe"; }
    Result<core::Image> render(const render::PreparedTexton&, const render::NoiseRequest& q,
                               render::RenderStats* = nullptr) override {
        const int now = ++active;
        for (int seen = most.load(); now > seen && !most.compare_exchange_weak(seen, now);) {
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        ++renders;
        --active;
        return core::Image(q.width, q.height, 3);
    }
    static std::atomic<int> active, most, renders;
};
std::atomic<int> OverlapProbe::active{0}, OverlapProbe::most{0}, OverlapProbe::renders{0};

// auto measures tiles as the server renders them: sixteen on every worker (a CPU render slot, a
// GL lane) at once, and the figure is sixteen tiles' share of the wall time.
TEST(BackendFactory, CalibrationRendersOnEveryWorkerAtOnce) {
    OverlapProbe a, b, c;
    auto out = render::calibrate({&a, &b, &c, &c}, a, true);
    ASSERT_TRUE(out.ok()) << out.error().message;
    EXPECT_EQ(OverlapProbe::most.load(), 4); // the two slots of `c` too
    // Warm-ups (the frame, then a tile on each worker), 16 tiles a worker a round, a frame a
    // round; at least the rounds that show a settled time.
    const render::Calibration& got = out.value();
    EXPECT_GE(got.tile_rounds, 4);
    EXPECT_GE(got.frame_rounds, 4);
    EXPECT_EQ(OverlapProbe::renders.load(), 1 + 4 + got.tile_rounds * 16 * 4 + got.frame_rounds);
    EXPECT_GT(got.tile_ms, 0);
}

// A backend that renders like a GPU at its idle clock until it has been busy a while: its first
// `slow` renders take 8 ms, the rest 1 ms.
class ClockRamp final : public render::Backend {
public:
    explicit ClockRamp(int slow) : m_slow(slow) {}
    std::string name() const override { return "ramp"; }
    std::string renderer() const override { return "ramp"; }
    Result<core::Image> render(const render::PreparedTexton&, const render::NoiseRequest& q,
                               render::RenderStats* = nullptr) override {
        std::this_thread::sleep_for(std::chrono::milliseconds(++m_calls <= m_slow ? 8 : 1));
        return core::Image(q.width, q.height, 3);
    }

private:
    int m_slow, m_calls = 0;
};

// The figure is the backend's once its clock has risen, not its idle clock's: 40 slow renders
// are the warm-up and two and a half rounds of sixteen tiles, whose median the calibration took
// before (128 ms where the settled round takes 16).
TEST(BackendFactory, CalibrationWaitsForTheClockToRise) {
    ClockRamp gpu(40), frames(3);
    auto out = render::calibrate({&gpu}, frames, true);
    ASSERT_TRUE(out.ok()) << out.error().message;
    EXPECT_GE(out.value().tile_rounds, 3 + 3); // past the ramp, then three no faster
    EXPECT_LT(out.value().tile_ms, 3 * 16.0) << out.value().tile_rounds << " rounds";
    EXPECT_LT(out.value().frame_ms, 3 * 1.0 + 2);
}

// The calibration itself, on whatever EGL finds (llvmpipe in CI): real figures for both
// candidates, and the choice follows them.
TEST(BackendFactory, AutoMeasuresEveryCandidate) {
    render::BackendOptions o;
    o.allow_software_egl = true;
    o.tile_slots = 2;
    o.quick_calibration = true;
    auto automatic = render::make_backend(render::BackendKind::automatic, o);
    ASSERT_TRUE(automatic.ok());
    const auto& c = automatic.value().calibration;
    if (c.empty()) GTEST_SKIP() << "no EGL at all: " << automatic.value().reason;
    ASSERT_EQ(c.size(), 2u);
    EXPECT_EQ(c[0].backend, "cpu");
    EXPECT_EQ(c[1].backend, "egl");
    for (const auto& f : c) {
        EXPECT_GT(f.tile_ms, 0);
        EXPECT_GT(f.frame_ms, 0);
    }
    const auto [t, f] = render::pick_fastest(c);
    EXPECT_EQ(automatic.value().tiles->name(), c[t].backend);
    EXPECT_EQ(automatic.value().backend->name(), c[f].backend);
    EXPECT_NE(automatic.value().reason.find("measured"), std::string::npos);
    // The lanes it measured the GL backend with go to the batcher when GL won anything.
    const auto& lanes = automatic.value().lanes;
    if (t == 1 || f == 1) {
        ASSERT_FALSE(lanes.empty());
        EXPECT_EQ(static_cast<int>(lanes.size()), render::gl_lanes(o, *lanes[0])); // 1 on llvmpipe
        EXPECT_EQ(std::static_pointer_cast<render::Backend>(lanes[0]),
                  t == 1 ? automatic.value().tiles : automatic.value().backend);
    } else {
        EXPECT_TRUE(lanes.empty());
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

// The façade the service uses: which backend serves which work, and the CPU where a backend has
// no path (a mix's limit levels on GL), each evaluation saying where it ran.
TEST(Renderer, RoutesWorkAndFallsBackToTheCpu) {
    using Work = render::Renderer::Work;
    auto cpu = render::Renderer::make(render::BackendKind::cpu, {});
    ASSERT_TRUE(cpu.ok());
    EXPECT_EQ(cpu.value()->tiles_backend(), "cpu");
    EXPECT_EQ(cpu.value()->frames_backend(), "cpu");
    EXPECT_EQ(cpu.value()->identity(), "cpu");

    auto gl = render::Renderer::make(render::BackendKind::osmesa, {});
    if (!gl) GTEST_SKIP() << "no OSMesa: " << gl.error().message;
    EXPECT_EQ(gl.value()->tiles_backend(), "osmesa");
    EXPECT_NE(gl.value()->identity().find("osmesa:"), std::string::npos);
    const auto tex = analysed_texton("etr_sand01.png", 32);
    render::NoiseRequest q;
    q.width = q.height = 64;
    std::string used;
    auto a = gl.value()->noise(*tex, q, Work::tile, &used);
    ASSERT_TRUE(a.ok());
    EXPECT_EQ(used, "osmesa");
    auto b = cpu.value()->noise(*tex, q, Work::frame, &used);
    ASSERT_TRUE(b.ok());
    EXPECT_EQ(used, "cpu");
    EXPECT_LE(max_abs_diff(a.value(), b.value()), 1e-5 * field_std(*tex, 0));

    core::MixField ramp;
    ramp.width = 200;
    const auto mix = analysed_mix("etr_sand01.png", "etr_pebbles04.png", 32, 3, ramp);
    q.level = mix->level(0).limit_level(); // GL has no limit levels for mixes
    auto m = gl.value()->mix(*mix, q, Work::tile, &used);
    ASSERT_TRUE(m.ok()) << m.error().message;
    EXPECT_EQ(used, "cpu");
    q.level = 0;
    ASSERT_TRUE(gl.value()->mix(*mix, q, Work::frame, &used).ok());
    EXPECT_EQ(used, "osmesa");

    // Surfaces and meshes: on GL when frames are GL.
    render::SurfaceRequest sr;
    const std::vector<float> pts = {0, 0, 0, 3, 1, 2}, nrm = {0, 0, 1, 0, 1, 0};
    auto s = gl.value()->surface(*tex, sr, pts, nrm, &used);
    ASSERT_TRUE(s.ok());
    EXPECT_EQ(used, "osmesa");
    EXPECT_EQ(s.value().size(), 2u * static_cast<std::size_t>(tex->channels()));
}

} // namespace
} // namespace textond::test
