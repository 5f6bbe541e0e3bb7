// A fourth kind of image, written here as an app::ImageSource the server does not have: the
// image workflow (ImageService) renders, times, resamples and keys it with no edit of its own,
// which is what one interface for textons, mixes and splats is for (server/README.md, "Adding a
// kind of image").
#include "render/renderer.h"
#include "server/app/image_service.h"
#include "server/app/image_source.h"
#include "server/app/metrics.h"
#include "server/app/texton_source.h"
#include "server/store/texton_store.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <memory>

namespace textond::test {
namespace {

constexpr float kGrey = 0.25f;

// One flat grey plane per id "known"; every other id is unknown.
class FlatSource final : public app::ImageSource {
public:
    using ImageSource::ImageSource;
    const char* collection() const override { return "flats"; }
    const char* described_as() const override { return "Flat grey "; }
    bool has_maps() const override { return false; }
    bool has_report() const override { return false; }
    Result<int> interpolation_order(const std::string& id) const override {
        if (id != "known") return make_error(ErrorCode::not_found, "no such flat");
        return 1;
    }
    Result<int> passes(const std::string& id, const api::MapChoice&) const override {
        return interpolation_order(id);
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
        j.request = app::noise_request(0, 512, -256, w, h, {});
        j.out_width = out_w;
        j.out_height = out_h;
        j.source = flats.get();
        return j;
    }
};

TEST(ImageSources, AFourthKindRendersResamplesAndIsTimedByTheBackendItNames) {
    Parts p;
    render::Cancel cancel;
    auto tile = p.images->render(p.job("known", 64, 32, 64, 32), cancel);
    ASSERT_TRUE(tile) << tile.error().message;
    EXPECT_EQ(tile.value().width, 64);
    EXPECT_EQ(tile.value().height, 32);
    EXPECT_EQ(tile.value().at(0, 63, 31), kGrey);
    // A tileable texture's resampling (ImageService's, not the source's) keeps a flat plane flat.
    auto resampled = p.images->render(p.job("known", 64, 64, 48, 40), cancel);
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
    auto none = p.images->render(p.job("unknown", 64, 64, 64, 64), cancel);
    ASSERT_FALSE(none);
    EXPECT_EQ(none.error().code, ErrorCode::not_found);
    EXPECT_EQ(p.flats->windows, 0);
    EXPECT_EQ(p.metrics.prometheus_text().find("backend=\"flat\""), std::string::npos);
}

TEST(ImageSources, KeysAndEtagsNameTheSourcesCollection) {
    Parts p;
    app::ImageService::Job flat = p.job("known", 256, 256, 256, 256);
    app::ImageService::Job texton = flat;
    texton.source = p.texton_source.get();
    const std::string key = app::ImageService::key(flat);
    EXPECT_EQ(key.rfind("flats/tile/known/0/512/-256/256x256/", 0), 0U) << key;
    EXPECT_NE(key, app::ImageService::key(texton)); // the same id in two collections: two images
    EXPECT_NE(p.images->etag(key), p.images->etag(app::ImageService::key(texton)));
    EXPECT_EQ(app::ImageService::report_key(*p.flats, "known", {}).rfind("flats/report/known/", 0),
              0U);
}

} // namespace
} // namespace textond::test
