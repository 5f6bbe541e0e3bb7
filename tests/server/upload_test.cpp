// Uploads: content addressing (201 then 200), raw and multipart bodies, metadata, the texton's
// files, listing, deletion, the API key, Prefer: respond-async and the 429 of a full queue.
#include "server/io/texton_file.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <thread>

namespace textond::test {
namespace {

using nlohmann::json;

TEST(Upload, RawThenMultipartGiveOneIdCreatedOnce) {
    TestServer server;
    auto c = server.client();
    const std::string body = read_file(exemplar_path("etr_sand01.png"));
    auto first = c.Post("/v1/textons?size=32&iterations=20", body, "image/png");
    ASSERT_TRUE(first);
    ASSERT_EQ(first->status, 201) << first->body;
    const json meta = json::parse(first->body);
    const std::string id = meta.at("id");
    EXPECT_EQ(first->get_header_value("Location"), "/v1/textons/" + id);
    EXPECT_EQ(meta.at("size"), 32);
    EXPECT_EQ(meta.at("iterations"), 20);
    EXPECT_EQ(meta.at("exemplar").at("width"), 256);
    EXPECT_EQ(meta.at("channels"), 3);
    EXPECT_GT(meta.at("rme").get<double>(), 0.0);
    EXPECT_LT(meta.at("rme").get<double>(), 1.0);
    EXPECT_FALSE(meta.at("created").get<std::string>().empty());
    EXPECT_EQ(meta.at("links").at("tilejson"), "/v1/textons/" + id + "/tilejson.json");

    auto again = c.Post("/v1/textons?size=32&iterations=20", body, "image/png");
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 200);
    EXPECT_EQ(json::parse(again->body).at("id"), id);

    // The same pixels and parameters as multipart form fields: the same texton.
    httplib::MultipartFormDataItems form = {{"exemplar", body, "sand.png", "image/png"},
                                            {"size", "32", "", ""},
                                            {"iterations", "20", "", ""}};
    auto multi = c.Post("/v1/textons", form);
    ASSERT_TRUE(multi);
    EXPECT_EQ(multi->status, 200) << multi->body;
    EXPECT_EQ(json::parse(multi->body).at("id"), id);
    // Other parameters, other texton.
    auto other = c.Post("/v1/textons?size=32&iterations=20&seed=1", body, "image/png");
    ASSERT_TRUE(other);
    EXPECT_EQ(other->status, 201);
    EXPECT_NE(json::parse(other->body).at("id"), id);
    EXPECT_EQ(server.service().metrics().analyses(), 2u);
}

TEST(Upload, MultipartCreatesOnAFreshServer) {
    TestServer server;
    auto c = server.client();
    httplib::MultipartFormDataItems form = {
        {"exemplar", read_file(exemplar_path("skimage_gravel.png")), "gravel.png", "image/png"},
        {"size", "32", "", ""}};
    auto res = c.Post("/v1/textons", form);
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 201) << res->body;
    EXPECT_EQ(json::parse(res->body).at("channels"), 1);
}

TEST(Upload, MetadataFilesListAndDelete) {
    TestServer server;
    auto c = server.client();
    const std::string a = upload(c, "etr_sand01.png", "?size=16&iterations=5");
    const std::string b = upload(c, "etr_pebbles04.png", "?size=16&iterations=5");
    ASSERT_FALSE(a.empty());
    ASSERT_FALSE(b.empty());

    auto meta = c.Get(("/v1/textons/" + a).c_str());
    ASSERT_TRUE(meta);
    EXPECT_EQ(meta->status, 200);
    EXPECT_EQ(json::parse(meta->body).at("id"), a);

    // texton.exr is the stored texton file: bit-exact coefficients with their checksum.
    auto exr = c.Get(("/v1/textons/" + a + "/texton.exr").c_str());
    ASSERT_TRUE(exr);
    ASSERT_EQ(exr->status, 200);
    EXPECT_EQ(exr->get_header_value("Content-Type"), "image/x-exr");
    const std::string path = temp_path("downloaded.exr");
    { std::ofstream(path, std::ios::binary) << exr->body; }
    auto record = io::read_texton_file(path);
    ASSERT_TRUE(record) << record.error().message;
    EXPECT_EQ(record.value().meta.id, a);
    EXPECT_EQ(record.value().texton.size, 16);

    auto png = c.Get(("/v1/textons/" + a + "/texton.png").c_str());
    ASSERT_TRUE(png);
    ASSERT_EQ(png->status, 200);
    const core::Image view = decode(png->body);
    EXPECT_EQ(view.width, 16);
    auto v1 = c.Get(("/v1/textons/" + a + "/texton.texton").c_str());
    ASSERT_TRUE(v1);
    EXPECT_EQ(v1->body.rfind("TEXTON\n1\n", 0), 0u);

    // Pages of one, in id order, chained by `next`.
    auto page = c.Get("/v1/textons?limit=1");
    ASSERT_TRUE(page);
    const json p1 = json::parse(page->body);
    ASSERT_EQ(p1.at("items").size(), 1u);
    EXPECT_EQ(p1.at("total"), 2);
    ASSERT_TRUE(p1.at("next").is_string());
    auto page2 = c.Get(p1.at("next").get<std::string>().c_str());
    ASSERT_TRUE(page2);
    const json p2 = json::parse(page2->body);
    ASSERT_EQ(p2.at("items").size(), 1u);
    EXPECT_LT(p1["items"][0]["id"].get<std::string>(), p2["items"][0]["id"].get<std::string>());
    EXPECT_TRUE(p2.at("next").is_null());

    // A tile before deletion is cached; after it, texton and tiles are gone.
    ASSERT_EQ(c.Get(("/v1/textons/" + a + "/tiles/0/0/0.png").c_str())->status, 200);
    EXPECT_TRUE(std::filesystem::exists(server.data_dir() + "/exemplars/" + a + ".png"));
    auto del = c.Delete(("/v1/textons/" + a).c_str());
    ASSERT_TRUE(del);
    EXPECT_EQ(del->status, 204);
    EXPECT_FALSE(std::filesystem::exists(server.data_dir() + "/exemplars/" + a + ".png"));
    // A texton stored before exemplars were kept: its views say so, its tiles still work.
    std::filesystem::remove(server.data_dir() + "/exemplars/" + b + ".png");
    auto no_exemplar = c.Get(("/v1/textons/" + b + "/exemplar.png").c_str());
    EXPECT_EQ(no_exemplar->status, 404);
    EXPECT_NE(no_exemplar->body.find("has no stored exemplar"), std::string::npos);
    EXPECT_EQ(c.Get(("/v1/textons/" + b + "/spectrum.png").c_str())->status, 404);
    EXPECT_EQ(c.Get(("/v1/textons/" + b + "/tiles/0/0/0.png").c_str())->status, 200);
    EXPECT_EQ(c.Get(("/v1/textons/" + a).c_str())->status, 404);
    EXPECT_EQ(c.Get(("/v1/textons/" + a + "/tiles/0/0/0.png").c_str())->status, 404);
    EXPECT_EQ(c.Delete(("/v1/textons/" + a).c_str())->status, 404);
    EXPECT_EQ(json::parse(c.Get("/v1/textons")->body).at("total"), 1);
}

TEST(Upload, ApiKeyGuardsEveryPostAndDelete) {
    http::ServeConfig config = TestServer::default_config();
    config.api_key = "s3cret";
    TestServer server(config);
    auto c = server.client();
    const std::string body = read_file(exemplar_path("etr_sand01.png"));
    auto denied = c.Post("/v1/textons?size=16&iterations=5", body, "image/png");
    ASSERT_TRUE(denied);
    EXPECT_EQ(denied->status, 401);
    EXPECT_EQ(json::parse(denied->body)["error"]["code"], "unauthorized");
    EXPECT_FALSE(denied->get_header_value("WWW-Authenticate").empty());
    httplib::Headers wrong = {{"Authorization", "Bearer s3creT"}};
    EXPECT_EQ(c.Post("/v1/textons?size=16&iterations=5", wrong, body, "image/png")->status, 401);
    httplib::Headers right = {{"Authorization", "Bearer s3cret"}};
    // The scheme's name in any case and one or more spaces after it (RFC 9110), the key exactly.
    httplib::Headers lower = {{"Authorization", "bearer s3cret"}};
    httplib::Headers spaced = {{"Authorization", "Bearer  s3cret"}};
    httplib::Headers glued = {{"Authorization", "Bearers3cret"}};
    httplib::Headers longer = {{"Authorization", "Bearer s3cret1"}};
    auto ok = c.Post("/v1/textons?size=16&iterations=5", right, body, "image/png");
    ASSERT_TRUE(ok);
    ASSERT_EQ(ok->status, 201);
    const std::string id = json::parse(ok->body).at("id");
    EXPECT_EQ(c.Get(("/v1/textons/" + id + "/tiles/0/0/0.png").c_str())->status, 200);
    // Surface and mesh renders are POSTs too (their body is no part of a signed URL).
    const std::string points = R"({"points": [[0, 0, 0]], "normals": [[0, 0, 1]]})";
    const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
    const std::string surface = "/v1/textons/" + id + "/surface";
    const std::string mesh = "/v1/textons/" + id + "/mesh.png?width=64&height=64";
    EXPECT_EQ(c.Post(surface.c_str(), points, "application/json")->status, 401);
    EXPECT_EQ(c.Post(mesh.c_str(), obj, "model/obj")->status, 401);
    EXPECT_EQ(c.Post(surface.c_str(), right, points, "application/json")->status, 200);
    EXPECT_EQ(c.Post(mesh.c_str(), right, obj, "model/obj")->status, 200);
    EXPECT_EQ(c.Delete(("/v1/textons/" + id).c_str())->status, 401);
    EXPECT_EQ(c.Delete(("/v1/textons/" + id).c_str(), glued)->status, 401);
    EXPECT_EQ(c.Delete(("/v1/textons/" + id).c_str(), longer)->status, 401);
    EXPECT_EQ(c.Post(surface.c_str(), lower, points, "application/json")->status, 200);
    EXPECT_EQ(c.Delete(("/v1/textons/" + id).c_str(), spaced)->status, 204);
}

TEST(Upload, RespondAsyncGives202AndAStatusUrl) {
    TestServer server;
    auto c = server.client();
    httplib::Headers prefer = {{"Prefer", "respond-async"}};
    auto res = c.Post("/v1/textons?size=64&iterations=300", prefer,
                      read_file(exemplar_path("mypaint_HR_Cork.png")), "image/png");
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 202) << res->body;
    const std::string status_url = res->get_header_value("Location");
    const std::string id = json::parse(res->body).at("id");
    EXPECT_EQ(status_url, "/v1/textons/" + id + "/status");
    json s;
    for (int i = 0; i < 600; ++i) {
        auto st = c.Get(status_url.c_str());
        ASSERT_TRUE(st);
        ASSERT_EQ(st->status, 200);
        s = json::parse(st->body);
        if (s.at("state") == "done" || s.at("state") == "failed") break;
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    EXPECT_EQ(s.at("state"), "done");
    EXPECT_EQ(s.at("progress").at("done"), 300);
    EXPECT_EQ(c.Get(("/v1/textons/" + id).c_str())->status, 200);
    // Deleted: its status is gone with it, though the pool still remembers the analysis.
    EXPECT_EQ(c.Delete(("/v1/textons/" + id).c_str())->status, 204);
    EXPECT_EQ(c.Get(status_url.c_str())->status, 404);
}

TEST(Upload, FullQueueAnswers429WithRetryAfter) {
    http::ServeConfig config = TestServer::default_config();
    config.analysis_workers = 1;
    config.analysis_queue = 0;
    TestServer server(config);
    auto c = server.client();
    httplib::Headers prefer = {{"Prefer", "respond-async"}};
    auto slow = c.Post("/v1/textons?size=64&iterations=300", prefer,
                       read_file(exemplar_path("mypaint_HR_Cork.png")), "image/png");
    ASSERT_TRUE(slow);
    ASSERT_EQ(slow->status, 202);
    auto refused = c.Post("/v1/textons?size=16&iterations=5",
                          read_file(exemplar_path("etr_sand01.png")), "image/png");
    ASSERT_TRUE(refused);
    EXPECT_EQ(refused->status, 429) << refused->body;
    EXPECT_EQ(json::parse(refused->body)["error"]["code"], "overloaded");
    EXPECT_GE(std::stoi(refused->get_header_value("Retry-After")), 1);
    // An identical upload joins the running analysis instead of being refused.
    auto joined = c.Post("/v1/textons?size=64&iterations=300", prefer,
                         read_file(exemplar_path("mypaint_HR_Cork.png")), "image/png");
    ASSERT_TRUE(joined);
    EXPECT_EQ(joined->status, 202);
}

} // namespace
} // namespace textond::test
