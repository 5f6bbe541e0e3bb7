// Tile formats for web pipelines over HTTP: .webp (lossless by default, lossy with
// quality=) and .avif, the same pixels as the PNG tile (exactly, or within a PSNR for the lossy
// ones); an extension-less tile URL answered by Accept with Vary: Accept; each format and quality
// its own ETag; @2x tiles are one level finer over the same square; the refusals.
#include "server/io/image_io.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"
#include "tests/support/web_decode.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <set>

namespace textond::test {
namespace {

double psnr(const core::Image& a, const core::Image& b) {
    double se = 0;
    for (int c = 0; c < 3; ++c)
        for (int y = 0; y < a.height; ++y)
            for (int x = 0; x < a.width; ++x) {
                const double d = a.at(std::min(c, a.channels - 1), x, y) -
                                 b.at(std::min(c, b.channels - 1), x, y);
                se += d * d;
            }
    const double mse = se / (3.0 * a.width * a.height);
    return mse == 0 ? INFINITY : 10 * std::log10(1.0 / mse);
}

httplib::Result get(httplib::Client& c, const std::string& path, const std::string& accept = "") {
    httplib::Headers h;
    if (!accept.empty()) h.emplace("Accept", accept);
    return c.Get(path, h);
}

TEST(Formats, WebpAndAvifTilesHoldThePngTilesPixels) {
    TestServer server;
    auto c = server.client();
    const std::string id = upload(c, "etr_pebbles04.png", "?size=32&iterations=20");
    const std::string tile = "/v1/textons/" + id + "/tiles/0/3/-2";
    auto png = get(c, tile + ".png?seed=5");
    ASSERT_TRUE(png && png->status == 200);
    const core::Image want = decode(png->body);

    auto lossless = get(c, tile + ".webp?seed=5");
    ASSERT_TRUE(lossless && lossless->status == 200) << (lossless ? lossless->body : "");
    EXPECT_EQ(lossless->get_header_value("Content-Type"), "image/webp");
    const core::Image exact = decode_webp(lossless->body).value();
    ASSERT_EQ(exact.width, 256);
    EXPECT_EQ(exact.data, want.data) << "lossless WebP must decode to the PNG's values";
    EXPECT_LT(lossless->body.size(), png->body.size() * 8 / 10) << "at least 20% smaller";

    auto lossy = get(c, tile + ".webp?seed=5&quality=90");
    ASSERT_TRUE(lossy && lossy->status == 200);
    EXPECT_LT(lossy->body.size(), png->body.size() / 4) << "quality 90 under a quarter";
    EXPECT_GT(psnr(want, decode_webp(lossy->body).value()), 30.0);
    EXPECT_NE(lossy->get_header_value("ETag"), lossless->get_header_value("ETag"));

    auto avif = get(c, tile + ".avif?seed=5");
    ASSERT_TRUE(avif && avif->status == 200) << (avif ? avif->body : "");
    EXPECT_EQ(avif->get_header_value("Content-Type"), "image/avif");
    const double avif_psnr = psnr(want, decode_avif(avif->body).value());
    EXPECT_GT(avif_psnr, 28.0);
    auto coarse = get(c, tile + ".avif?seed=5&quality=30");
    ASSERT_TRUE(coarse && coarse->status == 200);
    EXPECT_LT(coarse->body.size(), avif->body.size());
    EXPECT_LT(psnr(want, decode_avif(coarse->body).value()), avif_psnr);

    // The same URL twice: the same bytes, from the cache.
    EXPECT_EQ(get(c, tile + ".avif?seed=5")->body, avif->body);
    auto status = [&](const std::string& path) {
        auto r = get(c, path);
        return r ? std::to_string(r->status) + " " +
                       nlohmann::json::parse(r->body).at("error").at("code").get<std::string>()
                 : std::string("no answer");
    };
    EXPECT_EQ(status(tile + ".png?quality=90"), "400 invalid_parameter");
    EXPECT_EQ(status(tile + ".webp?quality=0"), "400 invalid_parameter");
    EXPECT_EQ(status(tile + ".avif?quality=101"), "400 invalid_parameter");
    EXPECT_EQ(status(tile + ".gif"), "400 invalid_format");
    // libwebp's largest side is 16383: refused before any render.
    EXPECT_EQ(status("/v1/textons/" + id + "/region.webp?w=16384&h=1"), "400 region_too_large");
}

TEST(Formats, ExtensionlessTilesFollowAcceptWithVary) {
    TestServer server;
    auto c = server.client();
    const std::string id = upload(c, "etr_sand01.png", "?size=32&iterations=20");
    const std::string tile = "/v1/textons/" + id + "/tiles/1/0/0";
    struct Case {
        const char* accept;
        const char* type;
    };
    std::set<std::string> etags;
    for (const Case& k :
         {Case{"image/avif,image/webp,image/apng,image/*,*/*;q=0.8", "image/avif"},
          Case{"image/webp,*/*", "image/webp"}, Case{"image/avif;q=0, image/webp", "image/webp"},
          Case{"IMAGE/WEBP", "image/webp"}, Case{"image/avif;q=0 ,image/webp", "image/webp"},
          Case{"image/avif; q=0; x=1, image/webp", "image/webp"}, Case{"*/*", "image/png"},
          Case{"", "image/png"}}) {
        auto r = get(c, tile + "?seed=2", k.accept);
        ASSERT_TRUE(r && r->status == 200) << k.accept;
        EXPECT_EQ(r->get_header_value("Content-Type"), k.type) << k.accept;
        EXPECT_EQ(r->get_header_value("Vary"), "Accept") << k.accept;
        etags.insert(r->get_header_value("ETag"));
        // The same bytes as the URL with the extension.
        const std::string ext = std::string(k.type).substr(6);
        EXPECT_EQ(r->body, get(c, tile + "." + ext + "?seed=2")->body) << k.accept;
    }
    EXPECT_EQ(etags.size(), 3u) << "one ETag per format";
    // A revalidation with the negotiated ETag: 304, still varying on Accept.
    auto first = get(c, tile + "?seed=2", "image/webp");
    httplib::Headers h = {{"Accept", "image/webp"},
                          {"If-None-Match", first->get_header_value("ETag")}};
    auto again = c.Get(tile + "?seed=2", h);
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 304);
    EXPECT_EQ(again->get_header_value("Vary"), "Accept");
    // Map tiles too.
    auto m = get(c, "/v1/textons/" + id + "/map/23/0/0?seed=2", "image/webp");
    ASSERT_TRUE(m && m->status == 200);
    EXPECT_EQ(m->get_header_value("Content-Type"), "image/webp");
}

TEST(Formats, RetinaTilesAreTheSameSquareOneLevelFiner) {
    TestServer server;
    auto c = server.client();
    const std::string id = upload(c, "etr_sand01.png", "?size=32&iterations=20");
    const std::string base = "/v1/textons/" + id;
    // Tile (z 2, x 3, y -1) of 256 covers texels [3072, 4096) x [-1024, 0); @2x draws it at level
    // 1 with 512 pixels: the region of level 1 at pixel (1536, -512).
    auto retina = get(c, base + "/tiles/2/3/-1@2x.png?seed=4");
    ASSERT_TRUE(retina && retina->status == 200) << (retina ? retina->body : "");
    auto region = get(c, base + "/region.png?z=1&x=1536&y=-512&w=512&h=512&seed=4");
    ASSERT_TRUE(region && region->status == 200);
    const core::Image a = decode(retina->body), b = decode(region->body);
    ASSERT_EQ(a.width, 512);
    EXPECT_EQ(a.data, b.data);
    // size=512 @2x: 1024 pixels; the finest level has no @2x.
    auto big = get(c, base + "/tiles/2/0/0@2x.webp?size=512&seed=4");
    ASSERT_TRUE(big && big->status == 200);
    EXPECT_EQ(decode_webp(big->body).value().width, 1024);
    auto finest = get(c, base + "/tiles/-4/0/0@2x.png");
    ASSERT_TRUE(finest);
    EXPECT_EQ(finest->status, 400);
}

} // namespace
} // namespace textond::test
