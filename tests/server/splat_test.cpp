// Splat maps over HTTP: POST /v1/splats from uploaded textons and an RGBA weight image or rules
// (content addressed: 201 then 200), the image endpoints under /v1/splats/{id}/ (tiles stitch into
// the region, TileJSON points at them, the report shows the weights), refusals, deleted layers and
// persistence across a restart.
#include "server/io/image_io.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace textond::test {
namespace {

using json = nlohmann::json;

// An RGBA PNG: R over the left half, G the right, B the bottom-left quarter, A nowhere.
std::string rgba_weights() {
    core::Image w(4, 4, 4);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) {
            w.at(0, x, y) = x < 2 ? 1.0f : 0.0f;
            w.at(1, x, y) = x >= 2 ? 1.0f : 0.0f;
            w.at(2, x, y) = x < 2 && y >= 2 ? 1.0f : 0.0f;
        }
    return io::encode_image_memory(w, io::Encoding::png8).value();
}

httplib::Result post_splat(httplib::Client& c, const httplib::MultipartFormDataItems& form) {
    return c.Post("/v1/splats", form);
}

TEST(Splats, CreateOnceThenServeWindowsOfOneFunction) {
    TestServer server;
    auto c = server.client();
    const std::string a = upload(c, "etr_sand01.png", "?size=16&iterations=10");
    const std::string b = upload(c, "etr_pebbles04.png", "?size=16&iterations=10");
    const std::string g = upload(c, "skimage_gravel.png", "?size=16&iterations=10");
    const std::string png = rgba_weights();
    const httplib::MultipartFormDataItems form = {{"textons", a + "," + b + "," + g, "", ""},
                                                  {"weights", png, "w.png", "image/png"},
                                                  {"scale", "64", "", ""},
                                                  {"x0", "-128", "", ""}};
    auto created = post_splat(c, form);
    ASSERT_TRUE(created);
    ASSERT_EQ(created->status, 201) << created->body;
    const json meta = json::parse(created->body);
    const std::string id = meta.at("id");
    EXPECT_EQ(created->get_header_value("Location"), "/v1/splats/" + id);
    EXPECT_EQ(meta["layers"], 3);
    EXPECT_EQ(meta["channels"], 3);
    EXPECT_EQ(meta["weights"]["kind"], "image");
    EXPECT_EQ(meta["weights"]["channels"], 3); // A is not a layer of three
    EXPECT_EQ(meta["links"]["quality_png"], "/v1/splats/" + id + "/quality.png");
    auto again = post_splat(c, form);
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 200);
    EXPECT_EQ(json::parse(again->body)["id"], id);
    EXPECT_EQ(c.Get(("/v1/splats/" + id).c_str())->status, 200);

    // Four tiles are the region, bit for bit, at two levels.
    for (int level : {0, 1}) {
        const std::string z = std::to_string(level);
        auto region = c.Get(
            ("/v1/splats/" + id + "/region.exr?x=-256&y=0&w=512&h=512&z=" + z + "&seed=4").c_str());
        ASSERT_TRUE(region && region->status == 200) << (region ? region->body : "");
        const core::Image whole = decode(region->body);
        for (int t = 0; t < 4; ++t) {
            auto tile =
                c.Get(("/v1/splats/" + id + "/tiles/" + z + "/" + std::to_string(-1 + t % 2) + "/" +
                       std::to_string(t / 2) + ".exr?seed=4")
                          .c_str());
            ASSERT_TRUE(tile && tile->status == 200);
            EXPECT_FALSE(tile->get_header_value("ETag").empty());
            EXPECT_EQ(max_abs_diff(decode(tile->body),
                                   window(whole, 256 * (t % 2), 256 * (t / 2), 256, 256)),
                      0.0)
                << "level " << level << " tile " << t;
        }
    }
    // Far left only layer a shows (weights clamp at the image's edge): its texton's own tile.
    auto far = c.Get(("/v1/splats/" + id + "/tiles/0/-40/-40.exr?seed=8").c_str());
    auto own = c.Get(("/v1/textons/" + a + "/tiles/0/-40/-40.exr?seed=8").c_str());
    ASSERT_TRUE(far && own && far->status == 200 && own->status == 200);
    EXPECT_EQ(max_abs_diff(decode(far->body), decode(own->body)), 0.0);

    auto tj = c.Get(("/v1/splats/" + id + "/tilejson.json").c_str());
    ASSERT_TRUE(tj && tj->status == 200);
    EXPECT_NE(tj->body.find("/v1/splats/" + id + "/map/{z}/{x}/{y}.png"), std::string::npos);
    EXPECT_EQ(c.Get(("/v1/splats/" + id + "/map/24/0/0.png").c_str())->status, 200);
    EXPECT_EQ(c.Get(("/v1/splats/" + id + "/tiles/2/0/0").c_str())->status, 200);

    // The report: the weights (palette colours) beside the result, 2 x 256 + 4 wide.
    auto report = c.Get(("/v1/splats/" + id + "/quality.png").c_str());
    ASSERT_TRUE(report && report->status == 200) << (report ? report->body : "");
    const core::Image r = decode(report->body);
    EXPECT_EQ(r.width, 516);
    EXPECT_EQ(r.height, 256);
    // Its left half: layer 1's colour at the top left, layer 2's at the top right.
    EXPECT_GT(r.at(0, 10, 10), r.at(2, 10, 10));   // orange: R > B
    EXPECT_LT(r.at(0, 240, 10), r.at(2, 240, 10)); // sky blue: B > R

    // A layer deleted: this server stops serving the splat at once (cached tiles too), and
    // serves it again, the same bytes, once the texton is back (the same id).
    const std::string kept = c.Get(("/v1/splats/" + id + "/tiles/1/2/2.exr?seed=6").c_str())->body;
    ASSERT_EQ(c.Delete(("/v1/textons/" + g).c_str())->status, 204);
    for (const std::string path : {"/tiles/1/2/2.exr?seed=6", "", "/tilejson.json"}) {
        auto res = c.Get(("/v1/splats/" + id + path).c_str());
        ASSERT_TRUE(res);
        EXPECT_EQ(res->status, 404) << path;
        EXPECT_NE(res->body.find(g), std::string::npos) << res->body;
    }
    EXPECT_EQ(upload(c, "skimage_gravel.png", "?size=16&iterations=10"), g);
    EXPECT_TRUE(c.Get(("/v1/splats/" + id + "/tiles/1/2/2.exr?seed=6").c_str())->body == kept);

    // A restart keeps the splat and serves the same bytes.
    const std::string before =
        c.Get(("/v1/splats/" + id + "/tiles/2/3/-1.exr?seed=9").c_str())->body;
    http::ServeConfig cfg = TestServer::default_config();
    cfg.data_dir = server.data_dir();
    TestServer restarted(cfg);
    auto c2 = restarted.client();
    EXPECT_TRUE(c2.Get(("/v1/splats/" + id + "/tiles/2/3/-1.exr?seed=9").c_str())->body == before);
    // A deleted layer: the splat is gone until the texton comes back (the same id).
    ASSERT_EQ(c2.Delete(("/v1/textons/" + g).c_str())->status, 204);
    TestServer third(cfg);
    auto c3 = third.client();
    auto gone = c3.Get(("/v1/splats/" + id + "/tiles/2/4/-1.png").c_str());
    ASSERT_TRUE(gone);
    EXPECT_EQ(gone->status, 404);
    EXPECT_NE(gone->body.find(g), std::string::npos) << gone->body;
}

TEST(Splats, RulesOnAHeightTexton) {
    TestServer server;
    auto c = server.client();
    const std::string a = upload(c, "etr_sand01.png", "?size=16&iterations=10");
    const std::string g = upload(c, "skimage_gravel.png", "?size=16&iterations=10"); // grey
    const std::string rules = R"({"height": ")" + g +
                              R"(", "height_soft": 0.02, "layers": [{"height": [null, 0.45]},)"
                              R"( {"height": [0.45, null], "slope": [0, 60]}]})";
    auto created = post_splat(c, {{"textons", a + "," + g, "", ""}, {"rules", rules, "", ""}});
    ASSERT_TRUE(created);
    ASSERT_EQ(created->status, 201) << created->body;
    const json meta = json::parse(created->body);
    EXPECT_EQ(meta["weights"]["kind"], "rules");
    EXPECT_EQ(meta["weights"]["layers"][0]["height"][0], nullptr);
    const std::string id = meta["id"];
    for (const char* path : {"/tiles/0/0/0.png", "/tiles/9/0/0.png", "/quality.png"}) {
        auto res = c.Get(("/v1/splats/" + id + path).c_str());
        ASSERT_TRUE(res);
        EXPECT_EQ(res->status, 200) << path << ": " << res->body;
    }
}

TEST(Splats, BadRequests) {
    TestServer server;
    auto c = server.client();
    const std::string a = upload(c, "etr_sand01.png", "?size=16&iterations=10");
    const std::string b = upload(c, "skimage_gravel.png", "?size=16&iterations=10");
    const std::string png = rgba_weights();
    const std::string two = a + "," + b, unknown(64, 'c');
    core::Image grey(2, 2, 1, 1.0f);
    const std::string grey_png = io::encode_image_memory(grey, io::Encoding::png8).value();
    struct Bad {
        httplib::MultipartFormDataItems form;
        int status;
        const char* code;
    };
    const std::vector<Bad> bad = {
        {{{"textons", two, "", ""}}, 400, "missing_weights"},
        {{{"textons", a, "", ""}, {"weights", png, "w.png", ""}}, 400, "invalid_parameter"},
        {{{"textons", two + "," + a + "," + b + "," + a + "," + b + "," + a + "," + b + "," + a, "",
           ""},
          {"weights", png, "w.png", ""},
          {"weights2", png, "w.png", ""}},
         400,
         "invalid_parameter"}, // nine
        {{{"textons", two + "," + a + "," + b + "," + a, "", ""}, {"weights", png, "w.png", ""}},
         400,
         "invalid_parameter"}, // five layers, one image
        {{{"textons", two + "," + a + "," + b + "," + a, "", ""},
          {"weights", grey_png, "w.png", ""},
          {"weights2", png, "w.png", ""}},
         400,
         "invalid_parameter"}, // five layers: weights must be RGBA
        {{{"textons", two, "", ""}, {"weights", png, "w.png", ""}, {"weights2", png, "w.png", ""}},
         400,
         "invalid_parameter"}, // weights2 is for layers 5 to 8
        {{{"textons", two, "", ""}, {"weights", grey_png, "w.png", ""}}, 400, "invalid_parameter"},
        {{{"textons", two, "", ""}, {"weights", "not an image", "w.png", ""}}, 415, nullptr},
        {{{"textons", two, "", ""}, {"weights", png, "w.png", ""}, {"scale", "0", "", ""}},
         400,
         "invalid_parameter"},
        {{{"textons", two, "", ""}, {"weights", png, "w.png", ""}, {"x0", "nan", "", ""}},
         400,
         "invalid_parameter"},
        {{{"textons", two, "", ""}, {"weights", png, "w.png", ""}, {"bogus", "1", "", ""}},
         400,
         "unknown_parameter"},
        {{{"textons", a + "," + unknown, "", ""}, {"weights", png, "w.png", ""}}, 404, "not_found"},
        {{{"textons", a + ",../../etc", "", ""}, {"weights", png, "w.png", ""}}, 400, "invalid_id"},
        {{{"textons", two, "", ""}, {"weights", png, "w.png", ""}, {"rules", "{}", "", ""}},
         400,
         "invalid_parameter"},
        {{{"textons", two, "", ""}, {"rules", "{", "", ""}}, 400, "invalid_parameter"},
        {{{"textons", two, "", ""},
          {"rules", R"({"height": ")" + b + R"(", "layers": [{}]})", "", ""}},
         400,
         "invalid_parameter"}, // one rule for two layers
        {{{"textons", two, "", ""},
          {"rules", R"({"height": ")" + a + R"(", "layers": [{}, {}]})", "", ""}},
         400,
         "invalid_parameter"}, // a colour height
        {{{"textons", two, "", ""},
          {"rules", R"({"height": ")" + b + R"(", "layers": [{"slope": [40, 30]}, {}]})", "", ""}},
         400,
         "invalid_parameter"},
        {{{"textons", two, "", ""},
          {"rules", R"({"height": ")" + b + R"(", "nope": 1, "layers": [{}, {}]})", "", ""}},
         400,
         "invalid_parameter"},
    };
    for (const Bad& x : bad) {
        auto res = post_splat(c, x.form);
        ASSERT_TRUE(res);
        EXPECT_EQ(res->status, x.status) << x.form[0].content << ": " << res->body;
        if (x.code) {
            EXPECT_EQ(json::parse(res->body)["error"]["code"].get<std::string>(), x.code)
                << res->body;
        }
    }
    auto raw = c.Post("/v1/splats", png, "image/png"); // not a form
    ASSERT_TRUE(raw);
    EXPECT_EQ(raw->status, 415);
    // A good splat refuses what its tiles cannot have.
    auto ok = post_splat(c, {{"textons", two, "", ""}, {"weights", png, "w.png", ""}});
    ASSERT_TRUE(ok && ok->status == 201) << (ok ? ok->body : "");
    const std::string id = json::parse(ok->body)["id"];
    for (const char* q : {"/tiles/0/0/0.png?map=albedo", "/tiles/0/0/0.png?marginals=exemplar",
                          "/tiles/0/0/0.gif", "/tilejson.json?marginals=exemplar"}) {
        auto res = c.Get(("/v1/splats/" + id + q).c_str());
        ASSERT_TRUE(res);
        EXPECT_EQ(res->status, 400) << q << ": " << res->body;
    }
    EXPECT_EQ(c.Get(("/v1/splats/" + unknown).c_str())->status, 404);
    EXPECT_EQ(c.Get(("/v1/splats/" + unknown + "/tiles/0/0/0.png").c_str())->status, 404);
    EXPECT_EQ(c.Get("/v1/splats/..%2F..%2Fetc/tiles/0/0/0.png")->status, 400);
    EXPECT_EQ(c.Get(("/v1/splats/" + id + "/nothing").c_str())->status, 404);
    EXPECT_EQ(c.Get("/healthz")->status, 200);
}

} // namespace
} // namespace textond::test
