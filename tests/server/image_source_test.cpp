// A fourth kind of image, written here as an app::ImageSource the server does not have: the
// image workflow (ImageService) renders, times, resamples and keys it, and install_image_routes
// serves its tiles, map tiles, region and TileJSON over HTTP, with no edit of their own. That is
// what one interface for textons, mixes and splats is for (server/README.md, "Adding a kind of
// image").
#include "render/renderer.h"
#include "server/app/image_service.h"
#include "server/app/image_source.h"
#include "server/app/metrics.h"
#include "server/app/texton_source.h"
#include "server/http/gate.h"
#include "server/http/image_routes.h"
#include "server/io/image_io.h"
#include "server/store/image_cache.h"
#include "server/store/texton_store.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <memory>
#include <thread>

namespace textond::test {
namespace {

constexpr float kGrey = 0.25f;
const std::string kKnown(64, 'f'); // an id as the routes check them
const std::string kUnknown(64, 'e');

// One flat grey plane, id kKnown; every other id is unknown.
class FlatSource final : public app::ImageSource {
public:
    using ImageSource::ImageSource;
    const char* collection() const override { return "flats"; }
    const char* described_as() const override { return "Flat grey "; }
    bool has_maps() const override { return false; }
    bool has_report() const override { return false; }
    Result<int> interpolation_order(const std::string& id) const override {
        if (id != kKnown) return make_error(ErrorCode::not_found, "no such flat");
        return 1;
    }
    Result<WindowCost> cost(const std::string& id, const api::MapChoice&) const override {
        if (auto order = interpolation_order(id); !order) return order.error();
        return WindowCost{};
    }
    std::optional<Error> tilejson_refusal(const std::string& id,
                                          const api::NoiseParams&) const override {
        if (auto order = interpolation_order(id); !order) return order.error();
        return std::nullopt;
    }
    int windows = 0; // prepared and run

protected:
    Result<Evaluate> prepare(const std::string& id, const render::NoiseRequest& q, Work,
                             const api::MapChoice&) override {
        if (auto order = interpolation_order(id); !order) return order.error();
        return Evaluate([this, w = q.width, h = q.height](std::string* used) {
            ++windows;
            *used = "flat";
            return Result<core::Image>(core::Image(w, h, 1, kGrey));
        });
    }
};

struct Parts {
    std::string dir = temp_path("image-source");
    std::unique_ptr<store::TextonStore> textons;
    std::unique_ptr<render::Renderer> renderer;
    app::Metrics metrics;
    std::unique_ptr<app::TextonSource> texton_source;
    std::unique_ptr<app::ImageService> images;
    std::unique_ptr<FlatSource> flats;
    Parts() {
        textons = std::move(store::TextonStore::open(dir).value());
        renderer = std::move(render::Renderer::make(render::BackendKind::cpu, {}).value());
        texton_source = std::make_unique<app::TextonSource>(*textons, *renderer, metrics);
        images = std::make_unique<app::ImageService>(*texton_source, *renderer, 6);
        flats = std::make_unique<FlatSource>(*renderer, metrics);
    }
    ~Parts() { std::filesystem::remove_all(dir); }
    app::ImageService::Job job(const std::string& id, int w, int h, int out_w, int out_h) {
        app::ImageService::Job j;
        j.id = id;
        j.request = app::to_noise_request(0, 512, -256, w, h, {});
        j.out_width = out_w;
        j.out_height = out_h;
        j.source = flats.get();
        return j;
    }
};

TEST(ImageSources, AFourthKindRendersResamplesAndIsTimedByTheBackendItNames) {
    Parts p;
    render::Cancel cancel;
    auto tile = p.images->render(p.job(kKnown, 64, 32, 64, 32), cancel);
    ASSERT_TRUE(tile) << tile.error().message;
    EXPECT_EQ(tile.value().width, 64);
    EXPECT_EQ(tile.value().height, 32);
    EXPECT_EQ(tile.value().at(0, 63, 31), kGrey);
    // A tileable texture's resampling (ImageService's, not the source's) keeps a flat plane flat.
    auto resampled = p.images->render(p.job(kKnown, 64, 64, 48, 40), cancel);
    ASSERT_TRUE(resampled) << resampled.error().message;
    EXPECT_EQ(resampled.value().width, 48);
    EXPECT_EQ(resampled.value().height, 40);
    EXPECT_NEAR(resampled.value().at(0, 17, 23), kGrey, 1e-5);
    EXPECT_EQ(p.flats->windows, 2);
    EXPECT_NE(p.metrics.prometheus_text().find(
                  "textond_render_seconds_count{backend=\"flat\",kind=\"tile\"} 2"),
              std::string::npos)
        << p.metrics.prometheus_text();
}

TEST(ImageSources, AnUnknownIdIsRefusedBeforeAnyWindowRuns) {
    Parts p;
    render::Cancel cancel;
    auto none = p.images->render(p.job(kUnknown, 64, 64, 64, 64), cancel);
    ASSERT_FALSE(none);
    EXPECT_EQ(none.error().code, ErrorCode::not_found);
    EXPECT_EQ(p.flats->windows, 0);
    EXPECT_EQ(p.metrics.prometheus_text().find("backend=\"flat\""), std::string::npos);
}

TEST(ImageSources, KeysAndEtagsNameTheSourcesCollection) {
    Parts p;
    app::ImageService::Job flat = p.job(kKnown, 256, 256, 256, 256);
    app::ImageService::Job texton = flat;
    texton.source = p.texton_source.get();
    const std::string key = app::ImageService::key(flat);
    EXPECT_EQ(key.rfind("flats/tile/" + kKnown + "/0/512/-256/256x256/", 0), 0U) << key;
    EXPECT_NE(key, app::ImageService::key(texton)); // the same id in two collections: two images
    EXPECT_NE(p.images->etag(key), p.images->etag(app::ImageService::key(texton)));
    EXPECT_EQ(
        app::ImageService::report_key(*p.flats, kKnown, {}).rfind("flats/report/" + kKnown, 0), 0U);
}

TEST(ImageSources, AFourthKindGetsTheImageRoutesFromOneCall) {
    Parts p;
    const http::ServeConfig config = TestServer::default_config();
    http::Gate gate(config, p.metrics);
    store::ImageCache cache(std::size_t{64} << 20);
    int port = 0;
    http::ImageRoutes routes(config, *p.images, *p.texton_source, cache, gate, p.metrics, port);
    httplib::Server server;
    http::install_image_routes(server, routes, *p.flats);
    port = server.bind_to_any_port("127.0.0.1");
    ASSERT_GT(port, 0);
    std::thread listening([&] { server.listen_after_bind(); });
    httplib::Client c("127.0.0.1", port);
    const std::string base = "/v1/flats/" + kKnown;

    auto tile = c.Get(base + "/tiles/0/3/-2.png");
    ASSERT_TRUE(tile);
    EXPECT_EQ(tile->status, 200) << tile->body;
    auto decoded = io::decode_image_memory(tile->body);
    ASSERT_TRUE(decoded);
    EXPECT_EQ(decoded.value().width, 256);
    EXPECT_NEAR(decoded.value().at(0, 100, 100), kGrey, 1.0 / 255);
    const std::string etag = tile->get_header_value("ETag");
    EXPECT_FALSE(etag.empty());
    auto again = c.Get(base + "/tiles/0/3/-2.png", {{"If-None-Match", etag}});
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 304);
    EXPECT_EQ(p.flats->windows, 1); // the second answer came from the cache's ETag

    auto map_tile = c.Get(base + "/map/24/3/-2.png"); // zoom 24: level 0, the same window
    ASSERT_TRUE(map_tile);
    EXPECT_EQ(map_tile->status, 200);
    EXPECT_EQ(map_tile->get_header_value("ETag"), etag); // one image, one key
    EXPECT_EQ(p.flats->windows, 1);
    auto region = c.Get(base + "/region.png?x=0&y=0&w=100&h=60");
    ASSERT_TRUE(region);
    ASSERT_EQ(region->status, 200) << region->body;
    EXPECT_EQ(io::decode_image_memory(region->body).value().height, 60);

    auto tilejson = c.Get(base + "/tilejson.json");
    ASSERT_TRUE(tilejson);
    ASSERT_EQ(tilejson->status, 200) << tilejson->body;
    const auto j = nlohmann::json::parse(tilejson->body);
    EXPECT_NE(j["tiles"][0].get<std::string>().find(base + "/map/{z}/{x}/{y}.png"),
              std::string::npos)
        << j.dump();
    EXPECT_EQ(j["description"].get<std::string>().rfind("Flat grey " + kKnown, 0), 0U);

    // Its refusals: an unknown id, a map= it does not take (has_maps), a report it has not.
    auto unknown = c.Get("/v1/flats/" + kUnknown + "/tiles/0/0/0.png");
    ASSERT_TRUE(unknown);
    EXPECT_EQ(unknown->status, 404);
    auto with_map = c.Get(base + "/tiles/0/0/0.png?map=height");
    ASSERT_TRUE(with_map);
    EXPECT_EQ(with_map->status, 400);
    EXPECT_NE(with_map->body.find("unknown_parameter"), std::string::npos) << with_map->body;
    auto report = c.Get(base + "/quality.png");
    ASSERT_TRUE(report);
    EXPECT_EQ(report->status, 404);

    server.stop();
    listening.join();
}

} // namespace
} // namespace textond::test
