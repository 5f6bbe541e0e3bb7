// Surface noise over HTTP: POST /v1/textons/{id}/surface (JSON and binary float32, the same
// colours as the library's evaluation of the stored texton) and POST /v1/textons/{id}/mesh.png.
#include "render/gl/osmesa_backend.h"
#include "render/surface_eval.h"
#include "server/io/texton_file.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <limits>

namespace textond::test {
namespace {

std::string sphere_obj(int n, int m) {
    std::string s = "# a UV sphere\n";
    const double pi = 3.14159265358979323846;
    for (int i = 0; i <= n; ++i)
        for (int j = 0; j < m; ++j) {
            const double th = pi * i / n, ph = 2 * pi * j / m;
            s += "v " + std::to_string(std::sin(th) * std::cos(ph)) + " " +
                 std::to_string(std::cos(th)) + " " + std::to_string(std::sin(th) * std::sin(ph)) +
                 "\n";
        }
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < m; ++j) {
            const int a = i * m + j + 1, b = i * m + (j + 1) % m + 1, c = a + m, d = b + m;
            s += "f " + std::to_string(a) + "/1/1 " + std::to_string(c) + " " + std::to_string(d) +
                 " " + std::to_string(b) + "\n";
        }
    return s;
}

TEST(Surface, JsonAndBinaryGiveTheLibrarysColours) {
    TestServer server;
    auto c = server.client();
    const std::string id = upload(c, "etr_sand01.png", "?size=16&iterations=10");
    const std::vector<float> pts = {0, 0, 0, 100.5f, -2, 3, -1e5f, 7e4f, 12.25f};
    const std::vector<float> nrm = {0, 0, 1, 0, 2, 0, 1, 1, 1}; // normalised by the server
    nlohmann::json body = {{"points", nlohmann::json::array()},
                           {"normals", nlohmann::json::array()}};
    for (int i = 0; i < 3; ++i) {
        body["points"].push_back({pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]});
        body["normals"].push_back({nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]});
    }
    auto j = c.Post(("/v1/textons/" + id + "/surface?seed=5&scale=2").c_str(), body.dump(),
                    "application/json");
    ASSERT_TRUE(j && j->status == 200) << (j ? j->body : "");
    const auto colours = nlohmann::json::parse(j->body).at("colors");
    ASSERT_EQ(colours.size(), 3u);

    std::string bin(3 * 24, '\0');
    for (int i = 0; i < 3; ++i) {
        std::memcpy(&bin[24 * i], &pts[3 * i], 12);
        std::memcpy(&bin[24 * i + 12], &nrm[3 * i], 12);
    }
    httplib::Headers accept = {{"Accept", "application/octet-stream"}};
    auto b = c.Post(("/v1/textons/" + id + "/surface?seed=5&scale=2").c_str(), accept, bin,
                    "application/octet-stream");
    ASSERT_TRUE(b && b->status == 200);
    ASSERT_EQ(b->body.size(), 9 * sizeof(float));
    EXPECT_EQ(b->get_header_value("X-Textond-Channels"), "3");
    EXPECT_EQ(b->get_header_value("X-Textond-Backend"), "cpu");
    std::vector<float> got(9);
    std::memcpy(got.data(), b->body.data(), b->body.size());

    auto record = io::read_texton_file(server.data_dir() + "/textons/" + id + ".exr");
    ASSERT_TRUE(record.ok());
    render::SurfaceRequest sr;
    sr.seed = 5;
    sr.scale = 2;
    auto want = render::evaluate_surface(record.value().texton, sr, pts, nrm);
    ASSERT_TRUE(want.ok());
    for (int i = 0; i < 9; ++i) {
        EXPECT_EQ(got[static_cast<std::size_t>(i)], want.value()[static_cast<std::size_t>(i)]);
        EXPECT_EQ(
            colours[static_cast<std::size_t>(i / 3)][static_cast<std::size_t>(i % 3)].get<float>(),
            want.value()[static_cast<std::size_t>(i)]);
    }
    // Another seed, other colours.
    auto other = c.Post(("/v1/textons/" + id + "/surface?seed=6&scale=2").c_str(), accept, bin,
                        "application/octet-stream");
    EXPECT_NE(other->body, b->body);
    // marginals=exemplar: the same colours through level 0's tables of the stored texton.
    auto restored =
        c.Post(("/v1/textons/" + id + "/surface?seed=5&scale=2&marginals=exemplar").c_str(), accept,
               bin, "application/octet-stream");
    ASSERT_TRUE(restored && restored->status == 200) << (restored ? restored->body : "");
    std::vector<float> mapped = want.value();
    auto prepared = render::PreparedTexton::make(record.value().texton);
    ASSERT_TRUE(prepared.ok());
    for (std::size_t k = 0; k < mapped.size(); k += 3)
        prepared.value()->marginals(0)->apply(&mapped[k]);
    std::vector<float> got_restored(9);
    std::memcpy(got_restored.data(), restored->body.data(), restored->body.size());
    EXPECT_EQ(got_restored, mapped);
    EXPECT_NE(got_restored, got);
    EXPECT_EQ(c.Post(("/v1/textons/" + id + "/surface?marginals=x").c_str(), accept, bin,
                     "application/octet-stream")
                  ->status,
              400);

    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::string nan_bin = bin;
    std::memcpy(&nan_bin[4], &nan, 4);
    struct Bad {
        std::string path, body, type;
        int status;
    };
    const std::string s = "/v1/textons/" + id + "/surface";
    for (const Bad& x :
         {Bad{s, R"({"points":[[0,0,0]],"normals":[[0,0,0]]})", "application/json", 400},
          Bad{s, R"({"points":[[0,0,0]],"normals":[]})", "application/json", 400},
          Bad{s, R"({"points":[[0,0]],"normals":[[0,0,1]]})", "application/json", 400},
          Bad{s, "not json", "application/json", 400},
          Bad{s, bin.substr(0, 20), "application/octet-stream", 400},
          Bad{s, nan_bin, "application/octet-stream", 400},
          Bad{s + "?mni=0", bin, "application/octet-stream", 400},
          Bad{s + "?scale=-1", bin, "application/octet-stream", 400},
          Bad{s + "?lod=1", bin, "application/octet-stream", 400},
          Bad{"/v1/textons/" + std::string(64, 'c') + "/surface", bin, "application/octet-stream",
              404}}) {
        auto r = c.Post(x.path.c_str(), x.body, x.type.c_str());
        ASSERT_TRUE(r);
        EXPECT_EQ(r->status, x.status) << x.path << " " << x.body.substr(0, 40) << ": " << r->body;
    }
}

// With --backend osmesa the service evaluates on the GPU path (llvmpipe here): the same colours
// as the CPU's within float rounding, and the mesh preview through it.
TEST(Surface, GlBackendServesTheSameColours) {
    if (!render::make_osmesa_backend().ok()) GTEST_SKIP() << "no OSMesa";
    http::ServeConfig cfg = TestServer::default_config();
    cfg.backend = render::BackendKind::osmesa;
    TestServer server(cfg);
    auto c = server.client();
    const std::string id = upload(c, "etr_sand01.png", "?size=16&iterations=10");
    const std::string body = R"({"points":[[0,0,0],[100.5,-2,3],[-5000,7000,12.25]],)"
                             R"("normals":[[0,0,1],[0,2,0],[1,1,1]]})";
    auto r = c.Post(("/v1/textons/" + id + "/surface?seed=5").c_str(), body, "application/json");
    ASSERT_TRUE(r && r->status == 200) << (r ? r->body : "");
    EXPECT_EQ(r->get_header_value("X-Textond-Backend"), "osmesa");
    const auto got = nlohmann::json::parse(r->body).at("colors");
    auto record = io::read_texton_file(server.data_dir() + "/textons/" + id + ".exr");
    ASSERT_TRUE(record.ok());
    render::SurfaceRequest sr;
    sr.seed = 5;
    auto want = render::evaluate_surface(record.value().texton, sr,
                                         {0, 0, 0, 100.5f, -2, 3, -5000, 7000, 12.25f},
                                         {0, 0, 1, 0, 2, 0, 1, 1, 1});
    ASSERT_TRUE(want.ok());
    for (int i = 0; i < 9; ++i)
        EXPECT_NEAR(
            got[static_cast<std::size_t>(i / 3)][static_cast<std::size_t>(i % 3)].get<double>(),
            want.value()[static_cast<std::size_t>(i)], 1e-4);
    auto mesh = c.Post(("/v1/textons/" + id + "/mesh.png?width=32&height=32").c_str(),
                       sphere_obj(8, 16), "model/obj");
    ASSERT_TRUE(mesh && mesh->status == 200) << (mesh ? mesh->body : "");
    EXPECT_EQ(mesh->get_header_value("X-Textond-Backend"), "osmesa");
}

TEST(Surface, MeshPreviewDrawsTheObjTexturedWithoutUvs) {
    TestServer server;
    auto c = server.client();
    const std::string id = upload(c, "mypaint_HR_Cork.png", "?size=16&iterations=10");
    const std::string obj = sphere_obj(24, 48);
    auto r = c.Post(("/v1/textons/" + id + "/mesh.png?width=96&height=64&seed=2").c_str(), obj,
                    "model/obj");
    ASSERT_TRUE(r && r->status == 200) << (r ? r->body : "");
    EXPECT_EQ(r->get_header_value("Content-Type"), "image/png");
    const core::Image img = decode(r->body);
    ASSERT_EQ(img.width, 96);
    ASSERT_EQ(img.height, 64);
    EXPECT_EQ(static_cast<int>(r->body[25]), 6); // PNG colour type 6: RGBA, the background clear
    // The exemplar's marginals reach the mesh too: the mesh's pixels change, the background not.
    auto m = c.Post(
        ("/v1/textons/" + id + "/mesh.png?width=96&height=64&seed=2&marginals=exemplar").c_str(),
        obj, "model/obj");
    ASSERT_TRUE(m && m->status == 200) << (m ? m->body : "");
    const core::Image restored = decode(m->body);
    EXPECT_GT(max_abs_diff(restored, img), 0.002);
    for (int ch = 0; ch < img.channels; ++ch) EXPECT_EQ(restored.at(ch, 0, 0), img.at(ch, 0, 0));
    EXPECT_EQ(img.at(0, 0, 0) + img.at(1, 0, 0) + img.at(2, 0, 0), 0.0f); // background
    EXPECT_GT(img.at(0, 48, 32) + img.at(1, 48, 32), 0.2f);               // the sphere
    // Textured: the sphere's pixels are not one flat colour.
    double lo = 1, hi = 0;
    for (int y = 28; y < 36; ++y)
        for (int x = 44; x < 52; ++x) {
            lo = std::min(lo, double(img.at(1, x, y)));
            hi = std::max(hi, double(img.at(1, x, y)));
        }
    EXPECT_GT(hi - lo, 0.02);
    // An explicit camera looking from behind sees the same sphere; bad meshes and cameras fail.
    EXPECT_EQ(
        c.Post(
             ("/v1/textons/" + id + "/mesh.png?width=32&height=32&eye=0,0,-6&target=0,0,0").c_str(),
             obj, "model/obj")
            ->status,
        200);
    for (auto [query, body, status] :
         {std::tuple<std::string, std::string, int>{"", "v 0 0 0\nf 1 2 3\n", 422},
          {"", "v 0 0\n", 422},
          {"", "", 422},
          {"?eye=0,0,5", obj, 400},
          {"?width=4", obj, 400},
          {"?eye=0,0,0&target=0,0,0", obj, 400}}) {
        auto e = c.Post(("/v1/textons/" + id + "/mesh.png" + query).c_str(), body, "model/obj");
        ASSERT_TRUE(e);
        EXPECT_EQ(e->status, status) << query << " " << body.substr(0, 20) << ": " << e->body;
    }
}

} // namespace
} // namespace textond::test
