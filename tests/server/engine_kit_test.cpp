// The engine kit: unpacked with tar(1), its GLSL compiled under OSMesa from the kit's files alone
// and fed the kit's coefficients and parameters, reproduces the server's tiles; its HLSL passes
// glslang's HLSL front end.
#include "core/grid_poisson.h"
#include "render/gl/osmesa_backend.h"
#include "server/io/image_io.h"
#include "server/io/texton_file.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace textond::test {
namespace {

namespace fs = std::filesystem;

struct Kit {
    fs::path dir;
    nlohmann::json params;
};

Kit unpack(httplib::Client& c, const std::string& id, const std::string& query,
           const std::string& name) {
    auto res = c.Get("/v1/textons/" + id + "/kit.tar" + query);
    EXPECT_TRUE(res && res->status == 200) << (res ? res->body : "no answer");
    if (!res || res->status != 200) return {};
    EXPECT_EQ(res->get_header_value("Content-Type"), "application/x-tar");
    const fs::path root = fresh_dir(name);
    const fs::path tarball = root / "kit.tar";
    {
        std::ofstream f(tarball, std::ios::binary);
        f << res->body;
    }
    // GNU tar checks every header checksum; a bad one fails here.
    const std::string cmd = "tar -xf '" + tarball.string() + "' -C '" + root.string() + "'";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    Kit kit;
    kit.dir = root / ("textond-kit-" + id.substr(0, 12));
    kit.params = nlohmann::json::parse(read_file((kit.dir / "textond_kit.json").string()));
    return kit;
}

TEST(EngineKit, HoldsEveryFileTheReadmeNames) {
    TestServer server;
    auto c = server.client();
    const std::string id = upload(c, "etr_sand01.png", "?size=32&iterations=20");
    const Kit kit = unpack(c, id, "", "kit_files");
    for (const char* f :
         {"README.md", "textond_kit.json", "texton.exr", "texton16.png", "glsl/noise_lib.glsl",
          "glsl/texton_eval.glsl", "glsl/texton_noise.frag", "glsl/texton_noise.comp",
          "glsl/fullscreen.vert", "hlsl/texton_noise.hlsl", "NOISE_SPEC.md", "glsl/marginals.glsl",
          "marginals.exr"}) {
        EXPECT_TRUE(fs::exists(kit.dir / f)) << f;
        EXPECT_FALSE(read_file((kit.dir / f).string()).empty()) << f;
    }
    // The shaders and the spec are the repository's files byte for byte, the texton is the
    // stored file, and the README names this texton and this MNI.
    const fs::path src = TEXTOND_SOURCE_DIR;
    for (const auto& [in_kit, in_repo] : std::vector<std::pair<std::string, std::string>>{
             {"glsl/noise_lib.glsl", "render/glsl/noise_lib.glsl"},
             {"glsl/texton_eval.glsl", "render/glsl/texton_eval.glsl"},
             {"glsl/texton_noise.frag", "render/glsl/texton_noise.frag"},
             {"glsl/texton_noise.comp", "render/glsl/texton_noise.comp"},
             {"glsl/fullscreen.vert", "render/glsl/fullscreen.vert"},
             {"hlsl/texton_noise.hlsl", "render/hlsl/texton_noise.hlsl"},
             {"glsl/marginals.glsl", "render/glsl/marginals.glsl"},
             {"NOISE_SPEC.md", "render/NOISE_SPEC.md"}})
        EXPECT_EQ(read_file((kit.dir / in_kit).string()), read_file((src / in_repo).string()))
            << in_kit;
    EXPECT_EQ(read_file((kit.dir / "texton.exr").string()),
              c.Get("/v1/textons/" + id + "/texton.exr")->body);
    const std::string readme = read_file((kit.dir / "README.md").string());
    EXPECT_NE(readme.find("# textond engine kit: texton " + id), std::string::npos);
    // Relative to the server, so that one kit is the same bytes behind any host name.
    EXPECT_NE(readme.find("`/v1/textons/" + id + "/tiles/0/X/Y.exr?seed=S&mni=30`"),
              std::string::npos)
        << readme;
    EXPECT_EQ(readme.find('%'), std::string::npos) << "a placeholder left in the README";
    // The parameters are the texton's and the threshold table is the spec's for that MNI.
    EXPECT_EQ(kit.params["id"], id);
    EXPECT_EQ(kit.params["r"], 32);
    const core::noise::GridPoisson grid(32, 30.0);
    EXPECT_EQ(kit.params["cell_size"], grid.a);
    EXPECT_EQ(kit.params["poisson_thresholds"].get<std::vector<std::uint32_t>>(), grid.thresholds);
    // The marginal tables: 25 levels of 3 directions, each monotone (what the GLSL interpolates;
    // kit_shaders_test runs marginals.glsl against the CPU), with a sigma per level.
    const core::Image tables = io::decode_image_file((kit.dir / "marginals.exr").string()).value();
    ASSERT_EQ(tables.width, 256);
    ASSERT_EQ(tables.height, 75);
    for (int row = 0; row < 75; ++row)
        for (int x = 1; x < 256; ++x)
            ASSERT_GE(tables.at(0, x, row), tables.at(0, x - 1, row)) << "row " << row;
    EXPECT_EQ(kit.params["marginals"]["sigma"].size(), 25u);
    EXPECT_EQ(kit.params["marginals"]["basis"].size(), 3u);
    // Another MNI, another table; a bad one is a clear 400; an unknown id a 404.
    const Kit five = unpack(c, id, "?mni=5", "kit_mni5");
    EXPECT_EQ(five.params["poisson_thresholds"].get<std::vector<std::uint32_t>>(),
              core::noise::GridPoisson(32, 5.0).thresholds);
    EXPECT_EQ(c.Get("/v1/textons/" + id + "/kit.tar?mni=0")->status, 400);
    EXPECT_EQ(c.Get("/v1/textons/" + id + "/kit.tar?lod=2")->status, 400);
    EXPECT_EQ(c.Get("/v1/textons/" + std::string(64, 'a') + "/kit.tar")->status, 404);
    // Same kit, same bytes (so it caches like a tile), under one strong ETag that a client sends
    // back for a 304 (each fetch had sent the whole tar); another MNI, another tag.
    const auto a = c.Get("/v1/textons/" + id + "/kit.tar");
    const auto b = c.Get("/v1/textons/" + id + "/kit.tar");
    ASSERT_TRUE(a && b);
    EXPECT_EQ(a->body, b->body);
    const std::string etag = a->get_header_value("ETag");
    ASSERT_GE(etag.size(), 3u);
    EXPECT_EQ(etag.front(), '"');
    EXPECT_EQ(b->get_header_value("ETag"), etag);
    const auto again = c.Get("/v1/textons/" + id + "/kit.tar", {{"If-None-Match", etag}});
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 304);
    EXPECT_TRUE(again->body.empty());
    EXPECT_EQ(again->get_header_value("ETag"), etag);
    EXPECT_NE(c.Get("/v1/textons/" + id + "/kit.tar?mni=5")->get_header_value("ETag"), etag);
    // The 16-bit PNG decodes to the coefficients within its quantisation step.
    const core::Image exr = io::decode_image_file((kit.dir / "texton.exr").string()).value();
    const core::Image png = io::decode_image_file((kit.dir / "texton16.png").string()).value();
    const double offset = kit.params["png16_decode"]["offset"],
                 scale = kit.params["png16_decode"]["scale"];
    ASSERT_EQ(exr.data.size(), png.data.size());
    double worst = 0;
    for (std::size_t i = 0; i < exr.data.size(); ++i)
        worst = std::max(worst, std::fabs(offset + scale * png.data[i] - exr.data[i]));
    EXPECT_LE(worst, scale / 65535.0);
}

// What a game client does: the kit's shader files, the kit's texton.exr and JSON, nothing else
// from the server; the result is the server's tile to the cross-backend tolerance.
TEST(EngineKit, KitGlslUnderOsmesaReproducesTheServersTiles) {
    TestServer server;
    auto c = server.client();
    for (int order : {1, 3}) {
        const std::string id =
            upload(c, "etr_pebbles04.png", "?size=32&iterations=20&order=" + std::to_string(order));
        const Kit kit = unpack(c, id, "", "kit_gl_" + std::to_string(order));
        render::GlslSources sources;
        sources.vert = read_file((kit.dir / "glsl/fullscreen.vert").string());
        sources.lib = read_file((kit.dir / "glsl/noise_lib.glsl").string());
        sources.eval = read_file((kit.dir / "glsl/texton_eval.glsl").string());
        sources.frag = read_file((kit.dir / "glsl/texton_noise.frag").string());
        auto gl = render::make_osmesa_backend(sources);
        if (!gl) GTEST_SKIP() << "no OSMesa: " << gl.error().message;

        core::Texton t;
        t.alpha = io::decode_image_file((kit.dir / "texton.exr").string()).value();
        t.size = kit.params["r"];
        t.channels = kit.params["channels"];
        t.order = kit.params["order"];
        ASSERT_EQ(t.order, order);
        for (int ch = 0; ch < t.channels; ++ch)
            t.mean[static_cast<std::size_t>(ch)] = kit.params["mean"][static_cast<std::size_t>(ch)];
        auto prepared = render::PreparedTexton::make(t);
        ASSERT_TRUE(prepared.ok());
        double var = 0;
        for (int ch = 0; ch < 3; ++ch)
            var = std::max(var, prepared.value()->covariance()->at(ch, ch, 0, 0));

        struct Tile {
            std::int64_t x, y;
            std::uint64_t seed;
        };
        for (const Tile& tile : {Tile{0, 0, 0}, Tile{-3, 7, 12345},
                                 Tile{std::int64_t{1} << 30, -(std::int64_t{1} << 30), 9}}) {
            auto res = c.Get("/v1/textons/" + id + "/tiles/0/" + std::to_string(tile.x) + "/" +
                             std::to_string(tile.y) + ".exr?seed=" + std::to_string(tile.seed));
            ASSERT_TRUE(res && res->status == 200);
            const core::Image want = decode(res->body);
            render::NoiseRequest q;
            q.seed = tile.seed;
            q.mni = kit.params["mni"];
            q.x0 = 256 * tile.x;
            q.y0 = 256 * tile.y;
            auto got = gl.value()->render(*prepared.value(), q);
            ASSERT_TRUE(got.ok()) << got.error().message;
            EXPECT_LE(max_abs_diff(got.value(), want), 1e-5 * std::sqrt(var))
                << "order " << order << " tile " << tile.x << "," << tile.y;
        }
    }
}

TEST(EngineKit, HlslCompilesWithGlslangsHlslFrontEnd) {
    if (std::system("command -v glslangValidator >/dev/null 2>&1") != 0)
        GTEST_SKIP() << "glslangValidator not installed (docker/install-deps.sh installs it)";
    TestServer server;
    auto c = server.client();
    const std::string id = upload(c, "etr_sand01.png", "?size=16&iterations=5");
    const Kit kit = unpack(c, id, "", "kit_hlsl");
    const fs::path hlsl = kit.dir / "hlsl/texton_noise.hlsl";
    const std::string cmd = "glslangValidator -D -S frag -e main -V '" + hlsl.string() + "' -o '" +
                            (kit.dir / "texton_noise.spv").string() + "' >/dev/null";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    EXPECT_GT(fs::file_size(kit.dir / "texton_noise.spv"), 1000u);
}

// A material set's kit: the set's shaders (the repository's bytes; kit_shaders_test runs them
// against the CPU), its maps' layout and height channel, each map's coefficients as a 16-bit PNG
// within the quantisation step of the stored texton's channels, and no texton16.png (a PNG holds
// at most 4 channels; this set has 5).
TEST(EngineKit, MaterialSetKitHoldsEveryMapAndTheSetShaders) {
    TestServer server;
    auto c = server.client();
    const core::Image u = load_exemplar("etr_pebbles04.png");
    core::Image grey(u.width, u.height, 1), rough(u.width, u.height, 1);
    for (std::size_t k = 0; k < u.plane_size(); ++k) {
        grey.data[k] = (u.plane(0)[k] + u.plane(1)[k] + u.plane(2)[k]) / 3.0f;
        rough.data[k] = u.plane(0)[k] * u.plane(1)[k];
    }
    httplib::MultipartFormDataItems form = {
        {"albedo", read_file(exemplar_path("etr_pebbles04.png")), "a.png", "image/png"},
        {"height", io::encode_image_memory(grey, io::Encoding::png16).value(), "h.png",
         "image/png"},
        {"roughness", io::encode_image_memory(rough, io::Encoding::png8).value(), "r.png",
         "image/png"},
        {"size", "16", "", ""},
        {"iterations", "20", "", ""}};
    auto up = c.Post("/v1/textons", form);
    ASSERT_TRUE(up && up->status == 201) << (up ? up->body : "no answer");
    const std::string id = nlohmann::json::parse(up->body).at("id");
    // texton.png: the maps side by side in RGB (5 channels do not fit a PNG), grey maps grey.
    auto shown = c.Get("/v1/textons/" + id + "/texton.png");
    ASSERT_TRUE(shown && shown->status == 200) << (shown ? shown->body : "no answer");
    const core::Image view = io::decode_image_memory(shown->body).value();
    EXPECT_EQ(view.width, 3 * 16);
    EXPECT_EQ(view.height, 16);
    for (int y = 0; y < 16; ++y)
        for (int x = 16; x < 48; ++x) // height and roughness
            ASSERT_TRUE(view.at(0, x, y) == view.at(1, x, y) &&
                        view.at(1, x, y) == view.at(2, x, y));
    const Kit kit = unpack(c, id, "", "kit_set");
    const fs::path src = TEXTOND_SOURCE_DIR;
    for (const auto& [in_kit, in_repo] : std::vector<std::pair<std::string, std::string>>{
             {"glsl/material_eval.glsl", "render/glsl/material_eval.glsl"},
             {"glsl/material_noise.frag", "render/glsl/material_noise.frag"},
             {"hlsl/material_noise.hlsl", "render/hlsl/material_noise.hlsl"},
             {"hlsl/texton_noise.hlsl", "render/hlsl/texton_noise.hlsl"}})
        EXPECT_EQ(read_file((kit.dir / in_kit).string()), read_file((src / in_repo).string()))
            << in_kit;
    EXPECT_FALSE(fs::exists(kit.dir / "texton16.png"));
    EXPECT_EQ(kit.params["channels"], 5);
    ASSERT_EQ(kit.params["maps"].size(), 3u);
    EXPECT_EQ(kit.params["height_channel"], 3); // albedo 0..2, height 3, roughness 4
    EXPECT_GT(kit.params["limit_level"].get<int>(), 0);
    const std::string readme = read_file((kit.dir / "README.md").string());
    EXPECT_NE(readme.find("## A material set (albedo, height, roughness)"), std::string::npos);
    EXPECT_EQ(readme.find('%'), std::string::npos) << "a placeholder left in the README";
    auto record = io::read_texton_file((kit.dir / "texton.exr").string());
    ASSERT_TRUE(record.ok()) << record.error().message;
    const core::Image& exr = record.value().texton.alpha;
    ASSERT_EQ(exr.channels, 5);
    const double offset = kit.params["png16_decode"]["offset"],
                 scale = kit.params["png16_decode"]["scale"];
    for (const auto& m : kit.params["maps"]) {
        const core::Image png =
            io::decode_image_file((kit.dir / m.at("file").get<std::string>()).string()).value();
        const int first = m.at("first"), channels = m.at("channels");
        ASSERT_EQ(png.channels, channels) << m.dump();
        double worst = 0;
        for (int ch = 0; ch < channels; ++ch)
            for (int y = 0; y < exr.height; ++y)
                for (int x = 0; x < exr.width; ++x)
                    worst = std::max(worst, std::fabs(offset + scale * png.at(ch, x, y) -
                                                      exr.at(first + ch, x, y)));
        EXPECT_LE(worst, scale / 65535.0) << m.dump();
    }
}

} // namespace
} // namespace textond::test
