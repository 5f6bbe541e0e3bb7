// Texture mixes over HTTP: POST /v1/mixes from two uploaded textons (content addressed: one id
// for one request, 201 then 200), the image endpoints under /v1/mixes/{id}/ (tiles stitch into
// the region, TileJSON points at them), masks, bad requests, and persistence across a restart.
#include "core/working_window.h"
#include "render/cpu_backend.h"
#include "render/gl/osmesa_backend.h"
#include "server/app/work_cost.h"
#include "server/io/image_io.h"
#include "server/io/mix_file.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>

namespace textond::test {
namespace {

std::string post_mix(httplib::Client& c, const std::string& query, const std::string& body,
                     int expect) {
    auto res = body.empty() ? c.Post(("/v1/mixes" + query).c_str())
                            : c.Post(("/v1/mixes" + query).c_str(), body, "image/png");
    EXPECT_TRUE(res);
    if (!res) return "";
    EXPECT_EQ(res->status, expect) << query << ": " << res->body;
    if (res->status != 200 && res->status != 201) return "";
    return nlohmann::json::parse(res->body).at("id").get<std::string>();
}

TEST(Mixes, CreateOnceThenServeWindowsOfOneFunction) {
    TestServer server;
    auto c = server.client();
    const std::string u = upload(c, "etr_sand01.png", "?size=16&iterations=10");
    const std::string v = upload(c, "etr_pebbles04.png", "?size=16&iterations=10");
    const std::string q = "?u=" + u + "&v=" + v + "&levels=5&x0=-100&width=300";
    const std::string id = post_mix(c, q, "", 201);
    ASSERT_EQ(id.size(), 64u);
    EXPECT_EQ(post_mix(c, q, "", 200), id); // content addressed
    EXPECT_NE(post_mix(c, q + "&dy=1", "", 201), id);

    auto meta = c.Get(("/v1/mixes/" + id).c_str());
    ASSERT_TRUE(meta && meta->status == 200);
    const auto j = nlohmann::json::parse(meta->body);
    EXPECT_EQ(j["levels"], 5);
    EXPECT_EQ(j["rme"].size(), 5u);
    EXPECT_EQ(j["field"]["kind"], "ramp");
    EXPECT_EQ(j["u"], u);

    // Four 256 tiles at level 0 are the 512 region, across the whole ramp (bit-exact floats).
    auto region = c.Get(("/v1/mixes/" + id + "/region.exr?x=-256&y=0&w=512&h=512&seed=4").c_str());
    ASSERT_TRUE(region && region->status == 200) << (region ? region->body : "");
    const core::Image whole = decode(region->body);
    for (int t = 0; t < 4; ++t) {
        const int tx = -1 + t % 2, ty = t / 2;
        auto tile = c.Get(("/v1/mixes/" + id + "/tiles/0/" + std::to_string(tx) + "/" +
                           std::to_string(ty) + ".exr?seed=4")
                              .c_str());
        ASSERT_TRUE(tile && tile->status == 200);
        EXPECT_FALSE(tile->get_header_value("ETag").empty());
        const core::Image part = decode(tile->body);
        EXPECT_EQ(max_abs_diff(part, window(whole, 256 * (t % 2), 256 * ty, 256, 256)), 0.0)
            << "tile " << t;
    }
    // Far on either side: the two textures' mean colours.
    for (auto [x, tex] : {std::pair<int, std::string>{-40, u}, {40, v}}) {
        auto tile = c.Get(("/v1/mixes/" + id + "/tiles/0/" + std::to_string(x) + "/0.exr").c_str());
        ASSERT_TRUE(tile && tile->status == 200);
        const core::Image img = decode(tile->body);
        double s = 0;
        for (std::size_t k = 0; k < img.plane_size(); ++k) s += img.plane(1)[k];
        const auto tj = nlohmann::json::parse(c.Get(("/v1/textons/" + tex).c_str())->body);
        EXPECT_NEAR(s / double(img.plane_size()), tj["mean"][1].get<double>(), 0.02) << x;
    }
    auto tj = c.Get(("/v1/mixes/" + id + "/tilejson.json").c_str());
    ASSERT_TRUE(tj && tj->status == 200);
    EXPECT_NE(tj->body.find("/v1/mixes/" + id + "/map/{z}/{x}/{y}.png"), std::string::npos);
    EXPECT_EQ(c.Get(("/v1/mixes/" + id + "/map/24/0/0.png").c_str())->status, 200);

    // A restart keeps the mix and serves the same bytes.
    const std::string before =
        c.Get(("/v1/mixes/" + id + "/tiles/2/3/-1.exr?seed=9").c_str())->body;
    http::ServeConfig cfg = TestServer::default_config();
    cfg.data_dir = server.data_dir();
    TestServer again(cfg);
    auto c2 = again.client();
    // (Compared as a flag: a failure must not print 1 MB of EXR.)
    EXPECT_TRUE(c2.Get(("/v1/mixes/" + id + "/tiles/2/3/-1.exr?seed=9").c_str())->body == before);
}

// On --backend osmesa the exact levels render on OpenGL and the limit levels fall back to the CPU;
// both agree with the CPU's rendering of the stored mix.
TEST(Mixes, GlBackendServesTheSameTiles) {
    if (!render::make_osmesa_backend().ok()) GTEST_SKIP() << "no OSMesa";
    http::ServeConfig cfg = TestServer::default_config();
    cfg.backend = render::BackendKind::osmesa;
    TestServer server(cfg);
    auto c = server.client();
    const std::string u = upload(c, "etr_sand01.png", "?size=16&iterations=10");
    const std::string v = upload(c, "etr_pebbles04.png", "?size=16&iterations=10");
    const std::string id =
        post_mix(c, "?u=" + u + "&v=" + v + "&levels=5&x0=-50&width=200", "", 201);
    auto record = io::read_mix_files(server.data_dir() + "/mixes", id);
    ASSERT_TRUE(record.ok()) << record.error().message;
    auto mix = render::PreparedMix::make(record.value().levels, record.value().field);
    ASSERT_TRUE(mix.ok());
    render::CpuBackend cpu;
    for (int level : {0, 1, 20}) {
        auto tile = c.Get(
            ("/v1/mixes/" + id + "/tiles/" + std::to_string(level) + "/-1/0.exr?seed=2").c_str());
        ASSERT_TRUE(tile && tile->status == 200) << (tile ? tile->body : "");
        render::NoiseRequest q;
        q.seed = 2;
        q.level = level;
        q.x0 = -256;
        auto want = cpu.render_mix(*mix.value(), q);
        ASSERT_TRUE(want.ok());
        const double tol = level >= mix.value()->level(0).limit_level() ? 0.0 : 1e-5;
        EXPECT_LE(max_abs_diff(decode(tile->body), want.value()), tol) << "level " << level;
    }
    // Which backend rendered: OpenGL for the exact levels, the CPU for the limit one.
    const std::string metrics = c.Get("/metrics")->body;
    EXPECT_NE(metrics.find(R"(backend="osmesa",kind="tile")"), std::string::npos);
    EXPECT_NE(metrics.find(R"(backend="cpu",kind="tile")"), std::string::npos);
}

TEST(Mixes, MaskFieldAndBadRequests) {
    TestServer server;
    auto c = server.client();
    const std::string u = upload(c, "etr_sand01.png", "?size=16&iterations=10");
    const std::string v = upload(c, "skimage_gravel.png", "?size=16&iterations=10");
    core::Image mask(2, 2, 1);
    mask.at(0, 1, 0) = mask.at(0, 1, 1) = 1.0f;
    const std::string png = io::encode_image_memory(mask, io::Encoding::png8).value();
    const std::string base = "?u=" + u + "&v=" + v;
    const std::string id = post_mix(c, base + "&levels=3&scale=128", png, 201);
    EXPECT_EQ(post_mix(c, base + "&levels=3&scale=128", png, 200), id);
    auto meta = nlohmann::json::parse(c.Get(("/v1/mixes/" + id).c_str())->body);
    EXPECT_EQ(meta["field"]["kind"], "mask");
    EXPECT_EQ(meta["channels"], 3); // the grey exemplar was promoted
    EXPECT_EQ(c.Get(("/v1/mixes/" + id + "/tiles/0/0/0.png").c_str())->status, 200);

    const std::string unknown(64, 'b');
    struct Bad {
        std::string query, body;
        int status;
    };
    for (const Bad& b :
         {Bad{"?u=" + u, "", 400}, Bad{base + "&levels=1", "", 400},
          Bad{base + "&levels=65", "", 400}, Bad{base + "&dx=0&dy=0", "", 400},
          Bad{base + "&width=0", "", 400}, Bad{base + "&x0=nan", "", 400},
          Bad{base + "&x0=1e300", "", 400}, Bad{base + "&bogus=1", "", 400},
          Bad{base + "&scale=4", "", 400}, Bad{base + "&dx=1", png, 400},
          Bad{base + "&scale=0", png, 400}, Bad{base, "not an image", 415},
          Bad{"?u=" + u + "&v=" + unknown, "", 404}, Bad{"?u=../../etc&v=" + v, "", 400}}) {
        auto res = b.body.empty() ? c.Post(("/v1/mixes" + b.query).c_str())
                                  : c.Post(("/v1/mixes" + b.query).c_str(), b.body, "image/png");
        ASSERT_TRUE(res);
        EXPECT_EQ(res->status, b.status) << b.query << ": " << res->body;
        EXPECT_NE(res->body.find("\"code\""), std::string::npos) << b.query;
    }
    EXPECT_EQ(c.Get(("/v1/mixes/" + unknown).c_str())->status, 404);
    EXPECT_EQ(c.Get(("/v1/mixes/" + unknown + "/tiles/0/0/0.png").c_str())->status, 404);
    EXPECT_EQ(c.Get("/v1/mixes/..%2F..%2Fetc/tiles/0/0/0.png")->status, 400);
    EXPECT_EQ(c.Get(("/v1/mixes/" + id + "/tiles/0/0/0.gif").c_str())->status, 400);
    EXPECT_EQ(c.Get("/healthz")->status, 200);
}

// A mix is `levels` analyses over the exemplars' common grid: one estimated over
// --max-request-cpu-s is refused (413 work_too_large) before it takes the analysis pool, as an
// upload is; a smaller one runs. Estimates: 64 levels of 256 x 256 x 3 at 10 iterations about
// 0.97 s, 3 levels 0.05 s (server/app/work_cost.h, mix_work_s).
TEST(Mixes, OneOverTheCpuBudgetIsRefusedBeforeItRuns) {
    http::ServeConfig config = TestServer::default_config();
    config.max_request_cpu_s = 0.5;
    TestServer server(config);
    auto c = server.client();
    const std::string u = upload(c, "etr_sand01.png", "?size=16&iterations=10");
    const std::string v = upload(c, "etr_pebbles04.png", "?size=16&iterations=10");
    const std::string base = "?u=" + u + "&v=" + v;
    auto big = c.Post(("/v1/mixes" + base + "&levels=64").c_str());
    ASSERT_TRUE(big);
    EXPECT_EQ(big->status, 413);
    EXPECT_EQ(nlohmann::json::parse(big->body)["error"]["code"], "work_too_large") << big->body;
    EXPECT_NE(nlohmann::json::parse(big->body)["error"]["message"].get<std::string>().find(
                  "fewer levels"),
              std::string::npos)
        << big->body;
    const std::string metrics = c.Get("/metrics")->body;
    EXPECT_NE(metrics.find("textond_not_admitted_total{reason=\"too_large\"} 1"), std::string::npos)
        << metrics;
    EXPECT_EQ(post_mix(c, base + "&levels=3", "", 201).size(), 64u);
}

// If-Match on a DELETE (RFC 9110 13.1.1): textons and mixes have no entity tag (content
// addressed, they never change), so a tag list never holds (412, nothing deleted) and "*" holds
// where the resource is; where it is not, 404 whatever If-Match says.
TEST(Mixes, DeletesHonourIfMatch) {
    TestServer server;
    auto c = server.client();
    const std::string u = upload(c, "etr_sand01.png", "?size=16&iterations=5");
    const std::string v = upload(c, "etr_pebbles04.png", "?size=16&iterations=5");
    const std::string mix = post_mix(c, "?u=" + u + "&v=" + v + "&levels=2", "", 201);
    ASSERT_EQ(mix.size(), 64u);
    for (const std::string& path : {"/v1/mixes/" + mix, "/v1/textons/" + u}) {
        for (const char* im : {"\"x\"", "W/\"x\"", "\"a\", \"b\""}) {
            auto r = c.Delete(path.c_str(), {{"If-Match", im}});
            ASSERT_TRUE(r);
            EXPECT_EQ(r->status, 412) << path << " " << im;
            EXPECT_EQ(nlohmann::json::parse(r->body)["error"]["code"], "precondition_failed");
            EXPECT_EQ(c.Get(path.c_str())->status, 200) << path << " was deleted";
        }
        EXPECT_EQ(c.Delete(path.c_str(), {{"If-Match", "*"}})->status, 204) << path;
        EXPECT_EQ(c.Delete(path.c_str(), {{"If-Match", "\"x\""}})->status, 404) << path;
    }
    EXPECT_EQ(c.Delete(("/v1/textons/" + v).c_str())->status, 204);
}

// A grid with a side divisible by 7 (or 5) costs an analysis more a pixel than a power of two's
// (FFTW's radix-7 codelets): measured 1.56-1.76x a 1024 x 1024 grid's CPU a pixel at 1008 x 1008,
// 1.23-1.32x at 1000 x 1000 (server/app/work_cost.h). Admission must not take it at the price of
// a power of two.
TEST(Mixes, GridsWithSidesOfFiveOrSevenAreEstimatedAtTheirCost) {
    auto per_pixel = [](int side) {
        return app::mix_work_s(side, side, 3, 20, 4) / (static_cast<double>(side) * side);
    };
    EXPECT_GT(per_pixel(1008) / per_pixel(1024), 1.5);
    EXPECT_LT(per_pixel(1008) / per_pixel(1024), 2.5);
    EXPECT_GT(per_pixel(1000) / per_pixel(1024), 1.2);
    EXPECT_LT(per_pixel(1000) / per_pixel(1024), 1.8);
}

// Exemplars of 509 x 509 (a prime side) are mixed on a 504 x 504 grid (core::mix_grid: FFTW's
// fast sizes), whose id names the crop (builds before it mixed on 509 x 509 under the id without
// it); the mix loads again after a restart (its id checks out) and serves the same tile.
TEST(Mixes, PrimeSidedExemplarsAreMixedOnAFastFftGrid) {
    TestServer server;
    auto c = server.client();
    std::string ids[2];
    const char* names[2] = {"skimage_gravel.png", "skimage_brick.png"};
    for (int k = 0; k < 2; ++k) {
        const core::Image part = core::centred_part(load_exemplar(names[k]), 509, 509);
        auto up = c.Post("/v1/textons?size=16&iterations=5",
                         io::encode_image_memory(part, io::Encoding::png8).value(), "image/png");
        ASSERT_TRUE(up && (up->status == 201 || up->status == 200)) << (up ? up->body : "");
        ids[k] = nlohmann::json::parse(up->body).at("id").get<std::string>();
    }
    const std::string id = post_mix(c, "?u=" + ids[0] + "&v=" + ids[1] + "&levels=3", "", 201);
    ASSERT_EQ(id.size(), 64u);
    const auto meta = nlohmann::json::parse(c.Get(("/v1/mixes/" + id).c_str())->body);
    EXPECT_EQ(meta["grid"], nlohmann::json::array({504, 504}));
    auto record = io::read_mix_files(server.data_dir() + "/mixes", id);
    ASSERT_TRUE(record.ok()) << record.error().message;
    EXPECT_NE(id, io::mix_id(ids[0], ids[1], 3, record.value().field));
    EXPECT_EQ(id,
              io::mix_id(ids[0], ids[1], 3, record.value().field, std::array<int, 2>{504, 504}));
    const std::string path = "/v1/mixes/" + id + "/tiles/0/0/0.png?seed=3";
    const std::string before = c.Get(path.c_str())->body;
    http::ServeConfig cfg = TestServer::default_config();
    cfg.data_dir = server.data_dir();
    TestServer again(cfg);
    auto c2 = again.client();
    auto after = c2.Get(path.c_str());
    ASSERT_TRUE(after && after->status == 200) << (after ? after->body : "");
    EXPECT_TRUE(after->body == before);
}

// A field variant of a mix stored here takes its levels from it: created with both exemplars
// gone from the disk (an analysis would need them), and the same levels and tiles as the variant
// analysed afresh on another server.
TEST(Mixes, AFieldVariantTakesTheLevelsOfAMixOfTheSamePair) {
    TestServer server;
    auto c = server.client();
    const std::string u = upload(c, "etr_sand01.png", "?size=16&iterations=10");
    const std::string v = upload(c, "etr_pebbles04.png", "?size=16&iterations=10");
    const std::string q = "?u=" + u + "&v=" + v + "&levels=4";
    const std::string first = post_mix(c, q + "&dx=1", "", 201);
    ASSERT_EQ(first.size(), 64u);
    for (const std::string& id : {u, v})
        ASSERT_TRUE(std::filesystem::remove(server.data_dir() + "/exemplars/" + id + ".png"));
    const std::string variant = post_mix(c, q + "&dy=1&width=200", "", 201);
    ASSERT_EQ(variant.size(), 64u);
    // Another level count is not a variant: it needs the exemplars.
    post_mix(c, "?u=" + u + "&v=" + v + "&levels=3", "", 404);

    TestServer fresh;
    auto f = fresh.client();
    ASSERT_EQ(upload(f, "etr_sand01.png", "?size=16&iterations=10"), u);
    ASSERT_EQ(upload(f, "etr_pebbles04.png", "?size=16&iterations=10"), v);
    ASSERT_EQ(post_mix(f, q + "&dy=1&width=200", "", 201), variant);
    auto reused = io::read_mix_files(server.data_dir() + "/mixes", variant);
    auto analysed = io::read_mix_files(fresh.data_dir() + "/mixes", variant);
    ASSERT_TRUE(reused.ok() && analysed.ok());
    EXPECT_EQ(reused.value().meta.rme, analysed.value().meta.rme);
    EXPECT_EQ(reused.value().meta.grid, analysed.value().meta.grid);
    ASSERT_EQ(reused.value().levels.size(), 4u);
    for (std::size_t l = 0; l < 4; ++l)
        EXPECT_TRUE(reused.value().levels[l].alpha.data == analysed.value().levels[l].alpha.data)
            << "level " << l;
    const std::string tile = "/v1/mixes/" + variant + "/tiles/0/0/0.png?seed=5";
    EXPECT_TRUE(c.Get(tile.c_str())->body == f.Get(tile.c_str())->body);
}

} // namespace
} // namespace textond::test
