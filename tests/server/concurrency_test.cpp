// Concurrency over real HTTP: identical uploads share one analysis (single flight), and many
// clients fetching tiles at once all get the right bytes.
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <map>
#include <thread>

namespace textond::test {
namespace {

using nlohmann::json;

TEST(Concurrency, SixteenIdenticalUploadsRunOneAnalysis) {
    http::ServeConfig config = TestServer::default_config();
    config.analysis_queue = 0; // joining an analysis must not count against the queue
    TestServer server(config);
    const std::string body = read_file(exemplar_path("mypaint_HR_DecoPaper.png"));
    std::vector<int> status(16, 0);
    std::vector<std::string> ids(16);
    std::vector<std::thread> clients;
    for (int i = 0; i < 16; ++i)
        clients.emplace_back([&, i] {
            auto c = server.client();
            auto res = c.Post("/v1/textons?size=48&iterations=200", body, "image/png");
            if (!res) return;
            status[i] = res->status;
            ids[i] = json::parse(res->body).value("id", "");
        });
    for (auto& t : clients) t.join();
    int created = 0;
    for (int i = 0; i < 16; ++i) {
        EXPECT_TRUE(status[i] == 200 || status[i] == 201) << i << ": " << status[i];
        created += status[i] == 201;
        EXPECT_EQ(ids[i], ids[0]);
    }
    EXPECT_EQ(created, 1);
    EXPECT_EQ(server.service().metrics().analyses(), 1u);
    auto c = server.client();
    EXPECT_EQ(json::parse(c.Get("/v1/textons")->body).at("total"), 1);
}

TEST(Concurrency, SixtyFourClientsFetchingTilesGetTheRightBytes) {
    TestServer server;
    auto setup = server.client();
    const std::string id = upload(setup, "etr_floor01.png", "?size=32&iterations=20");
    ASSERT_FALSE(id.empty());
    // 16 distinct tiles, each fetched by 4 clients at once, cold; then compared with the bytes
    // of a second server rendering them one at a time.
    auto path = [&](int k) {
        return "/v1/textons/" + id + "/tiles/" + std::to_string(k % 3) + "/" +
               std::to_string(k - 8) + "/" + std::to_string(3 * k) +
               ".png?seed=" + std::to_string(k % 2);
    };
    std::vector<std::string> got(64);
    std::vector<int> status(64, 0);
    std::vector<std::thread> clients;
    for (int i = 0; i < 64; ++i)
        clients.emplace_back([&, i] {
            auto c = server.client();
            auto res = c.Get(path(i % 16).c_str());
            if (!res) return;
            status[i] = res->status;
            got[i] = res->body;
        });
    for (auto& t : clients) t.join();

    http::ServeConfig solo = TestServer::default_config();
    solo.render_slots = 1;
    solo.data_dir = server.data_dir(); // the same stored texton
    TestServer reference(solo);
    auto r = reference.client();
    for (int i = 0; i < 64; ++i) {
        ASSERT_EQ(status[i], 200) << i;
        auto want = r.Get(path(i % 16).c_str());
        ASSERT_TRUE(want);
        EXPECT_EQ(got[i], want->body) << "client " << i;
    }
    EXPECT_NE(got[0], got[1]);
}

} // namespace
} // namespace textond::test
