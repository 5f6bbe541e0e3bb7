// Rate limits on cold work (server/http/rate_limiter.h): the token bucket itself with a
// clock of the test's own, then over HTTP: a client's renders past its burst get 429
// rate_limited with Retry-After, cache hits and 304s are never counted, the --api-key holder has
// a bucket of its own, and /metrics counts the refusals.
#include "server/http/rate_limiter.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace textond::test {
namespace {

using http::RateLimiter;

TEST(RateLimit, BucketRefillsAtItsRateUpToItsBurst) {
    RateLimiter off(0, 5);
    double wait = 0;
    for (int i = 0; i < 100; ++i) EXPECT_TRUE(off.take("a", wait));

    RateLimiter limiter(2.0, 3.0); // 2 a second, 3 at once
    const auto t0 = RateLimiter::Clock::time_point{} + std::chrono::hours(1);
    for (int i = 0; i < 3; ++i) EXPECT_TRUE(limiter.take("a", wait, t0)) << i;
    EXPECT_FALSE(limiter.take("a", wait, t0));
    EXPECT_NEAR(wait, 0.5, 1e-9); // one token takes half a second
    EXPECT_TRUE(limiter.take("b", wait, t0)) << "another client has its own bucket";
    EXPECT_FALSE(limiter.take("a", wait, t0 + std::chrono::milliseconds(400)));
    EXPECT_TRUE(limiter.take("a", wait, t0 + std::chrono::milliseconds(500)));
    // A long pause refills to the burst, not beyond.
    const auto later = t0 + std::chrono::seconds(60);
    for (int i = 0; i < 3; ++i) EXPECT_TRUE(limiter.take("a", wait, later)) << i;
    EXPECT_FALSE(limiter.take("a", wait, later));
}

TEST(RateLimit, ClientsAreBoundedInMemory) {
    RateLimiter limiter(1.0, 1.0, 100);
    const auto t0 = RateLimiter::Clock::time_point{} + std::chrono::hours(1);
    double wait = 0;
    for (int i = 0; i < 1000; ++i)
        limiter.take("client" + std::to_string(i), wait, t0 + std::chrono::milliseconds(i));
    EXPECT_LE(limiter.clients(), 100u);
}

TEST(RateLimit, OnlyRendersCountAndTheKeyHolderHasItsOwnBucket) {
    auto config = TestServer::default_config();
    config.render_rate = 1; // a minute: nothing refills while the test runs
    config.render_burst = 2;
    config.api_key = "k3y";
    TestServer server(config);
    auto c = server.client();
    httplib::Headers key = {{"Authorization", "Bearer k3y"}};
    auto up = c.Post("/v1/textons?size=16&iterations=10", key,
                     read_file(exemplar_path("etr_sand01.png")), "image/png");
    ASSERT_TRUE(up && up->status == 201);
    const std::string base =
        "/v1/textons/" + nlohmann::json::parse(up->body).at("id").get<std::string>() + "/tiles/0/";
    // Two cold tiles: the burst. The third: 429, with a minute's Retry-After.
    auto first = c.Get(base + "0/0.png");
    ASSERT_TRUE(first && first->status == 200);
    EXPECT_EQ(c.Get(base + "1/0.png")->status, 200);
    auto third = c.Get(base + "2/0.png");
    ASSERT_TRUE(third);
    EXPECT_EQ(third->status, 429);
    EXPECT_EQ(nlohmann::json::parse(third->body).at("error").at("code"), "rate_limited");
    EXPECT_FALSE(third->has_header("ETag")) << "an error carries no validator";
    EXPECT_EQ(third->get_header_value_count("Cache-Control"), 1u);
    const int retry = std::stoi(third->get_header_value("Retry-After"));
    EXPECT_GE(retry, 50);
    EXPECT_LE(retry, 60);
    // Cached tiles and revalidations are not renders: served at any rate.
    for (int i = 0; i < 10; ++i) EXPECT_EQ(c.Get(base + "0/0.png")->status, 200) << i;
    httplib::Headers revalidate = {{"If-None-Match", first->get_header_value("ETag")}};
    EXPECT_EQ(c.Get(base + "0/0.png", revalidate)->status, 304);
    // The key's holder is another client; a made-up key is not.
    EXPECT_EQ(c.Get(base + "3/0.png", key)->status, 200);
    httplib::Headers made_up = {{"Authorization", "Bearer anything"}};
    EXPECT_EQ(c.Get(base + "4/0.png", made_up)->status, 429);
    const std::string metrics = c.Get("/metrics")->body;
    EXPECT_NE(metrics.find("textond_not_admitted_total{reason=\"rate_limited\"} 2"),
              std::string::npos)
        << metrics.substr(0, 2000);
}

} // namespace
} // namespace textond::test
