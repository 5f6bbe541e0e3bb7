// Concurrency over real HTTP: identical uploads share one analysis (single flight), and many
// clients fetching tiles at once all get the right bytes.
#include "render/gl/osmesa_backend.h"
#include "server/store/load_limit.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <thread>

namespace textond::test {
namespace {

using nlohmann::json;

// Loads of stored splats and mixes run one at a time and in the order they asked: one that
// waits behind a busy place gets its turn before any that asked later, and one whose turn does
// not come within its wait is refused (unavailable) and leaves the line.
TEST(Concurrency, LoadsRunOneAtATimeInTheOrderTheyAsked) {
    using namespace std::chrono_literals;
    store::LoadLimit limit(1);
    std::mutex m;
    std::vector<int> order;
    std::atomic<bool> release{false};
    std::atomic<int> running{0}, most{0};
    auto load = [&](int who) {
        return [&, who]() -> Result<int> {
            const int now = ++running;
            most = std::max(most.load(), now);
            {
                std::lock_guard lock(m);
                order.push_back(who);
            }
            while (who == 0 && !release) std::this_thread::sleep_for(1ms);
            std::this_thread::sleep_for(5ms);
            --running;
            return who;
        };
    };
    std::vector<std::thread> ts;
    ts.emplace_back([&] { EXPECT_TRUE(limit.run<int>("x", 10s, load(0)).ok()); });
    while (order.empty()) std::this_thread::sleep_for(1ms);
    Result<int> late = make_error(ErrorCode::internal, "not run");
    ts.emplace_back([&] { late = limit.run<int>("splats", 50ms, load(9)); });
    for (int who = 1; who <= 5; ++who) { // each asks after the one before
        ts.emplace_back([&, who] { EXPECT_TRUE(limit.run<int>("x", 10s, load(who)).ok()); });
        std::this_thread::sleep_for(20ms);
    }
    std::this_thread::sleep_for(100ms); // the one with a 50 ms wait gives up meanwhile
    release = true;
    for (auto& t : ts) t.join();
    EXPECT_EQ(order, (std::vector<int>{0, 1, 2, 3, 4, 5}));
    EXPECT_EQ(most.load(), 1);
    ASSERT_FALSE(late.ok());
    EXPECT_EQ(late.error().code, ErrorCode::unavailable);
}

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

// A GL backend gathers concurrent tiles into batches and rounds them on the GPU to the bits of
// the format (8 or 16); the bytes must still be the CPU's at every exact level, for tiles alone
// and for tiles that shared a batch.
TEST(Concurrency, BatchedGlTilesAreTheCpusBytes) {
    if (!render::make_osmesa_backend().ok()) GTEST_SKIP() << "no OSMesa";
    http::ServeConfig config = TestServer::default_config();
    config.backend = render::BackendKind::osmesa;
    config.gpu_batch_wait_us = 20000; // gather generously: llvmpipe is slow to fill a batch
    config.gpu_batch_ms = 60000;      // and lets no batch hold more than 25 ms of its work
    config.gpu_lanes = 2;             // two batches in flight, each on a context of its own
    TestServer gl(config);
    auto setup = gl.client();
    const std::string id = upload(setup, "etr_floor01.png", "?size=32&iterations=20");
    const std::string grey = upload(setup, "skimage_gravel.png", "?size=32&iterations=20");
    ASSERT_FALSE(id.empty() || grey.empty());
    // 8-bit formats (PNG, WebP) take the GPU's bytes as they are; 16 bits take floats.
    auto path = [&](int k) {
        const char* ext = k % 4 == 3 ? ".png16" : k % 8 == 5 ? ".webp" : ".png";
        return "/v1/textons/" + (k % 3 == 2 ? grey : id) + "/tiles/" + std::to_string(k % 3 - 1) +
               "/" + std::to_string(k - 8) + "/" + std::to_string(3 * k) + ext +
               "?seed=" + std::to_string(k % 2 ? 1ull << 33 : 5);
    };
    constexpr int kClients = 24;
    std::vector<std::string> got(kClients);
    std::vector<int> status(kClients, 0);
    std::vector<std::thread> clients;
    for (int i = 0; i < kClients; ++i)
        clients.emplace_back([&, i] {
            auto c = gl.client();
            auto res = c.Get(path(i).c_str());
            if (!res) return;
            status[i] = res->status;
            got[i] = res->body;
        });
    for (auto& t : clients) t.join();
    // Some tiles shared a batch.
    const std::string metrics = setup.Get("/metrics")->body;
    auto value = [&](const std::string& name) {
        const auto at = metrics.find("\n" + name + " ");
        return at == std::string::npos ? -1.0 : std::stod(metrics.substr(at + name.size() + 2));
    };
    EXPECT_GT(value("textond_gpu_batched_windows"), value("textond_gpu_batches"));
    EXPECT_GE(value("textond_gpu_batched_windows"), kClients);
    EXPECT_EQ(value("textond_gpu_lanes"), 2);

    http::ServeConfig cpu = TestServer::default_config();
    cpu.data_dir = gl.data_dir(); // the same stored texton
    TestServer reference(cpu);
    auto r = reference.client();
    for (int i = 0; i < kClients; ++i) {
        ASSERT_EQ(status[i], 200) << i;
        auto want = r.Get(path(i).c_str());
        ASSERT_TRUE(want);
        EXPECT_EQ(got[i], want->body) << path(i);
    }
    // And one alone.
    auto alone = setup.Get(path(kClients + 1).c_str());
    ASSERT_TRUE(alone && alone->status == 200);
    EXPECT_EQ(alone->body, r.Get(path(kClients + 1).c_str())->body);
}

// The admission estimate is the work's: pixels x MNI x taps. A region of 1024 x 1024 at order 1
// costs about 1.3 s of CPU at MNI 200 and 0.03 s at MNI 5; with a budget of 1 s the first is
// refused before it runs (413), the second served. Without the MNI factor both would pass.
TEST(Concurrency, AdmissionCountsTheDensityOfImpulses) {
    auto config = TestServer::default_config();
    config.max_request_cpu_s = 1.0;
    TestServer server(config);
    auto c = server.client();
    const std::string id = upload(c, "etr_sand01.png", "?size=16&iterations=10&order=1");
    const std::string region = "/v1/textons/" + id + "/region.png?w=1024&h=1024&mni=";
    auto dense = c.Get(region + "200");
    ASSERT_TRUE(dense);
    EXPECT_EQ(dense->status, 413) << dense->body.substr(0, 200);
    EXPECT_NE(dense->body.find("work_too_large"), std::string::npos) << dense->body;
    auto sparse = c.Get(region + "5");
    ASSERT_TRUE(sparse);
    EXPECT_EQ(sparse->status, 200) << sparse->body.substr(0, 200);
}

} // namespace
} // namespace textond::test
