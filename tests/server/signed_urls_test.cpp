// Signed URLs and presets (issue 19; server/http/url_signing.h) over HTTP: with a signing key a
// good signature gets 200 and a missing one, a tampered path, query, signature or expiry each a
// 403 with its code; one signature opens a whole tile layer, and a signed TileJSON hands out
// signed templates; `textond sign` signs as the server checks. With presets, URLs name one and
// carry nothing else, and get the preset's tile.
#include "server/http/url_signing.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <string>

namespace textond::test {
namespace {

const char* kKey = "correct horse battery staple";

std::int64_t now_s() {
    return std::chrono::duration_cast<std::chrono::seconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
}

// "STATUS CODE" of a GET (CODE empty on success).
std::string outcome(httplib::Client& c, const std::string& url) {
    auto r = c.Get(url);
    if (!r) return "no answer";
    if (r->status == 200) return "200";
    return std::to_string(r->status) + " " +
           nlohmann::json::parse(r->body).at("error").at("code").get<std::string>();
}

std::string sign(const std::string& url, std::int64_t exp = 0) {
    return http::sign_url(kKey, url, exp).value();
}

TEST(SignedUrls, GoodSignaturesPassAndEveryTamperingIsRefused) {
    // An unsigned server's id for the same photo, to upload on the signed one (uploads are POST,
    // under --api-key, not signatures).
    auto config = TestServer::default_config();
    config.url_signing_key = kKey;
    TestServer server(config);
    auto c = server.client();
    const std::string id = upload(c, "etr_sand01.png", "?size=16&iterations=10");
    const std::string other = upload(c, "skimage_gravel.png", "?size=16&iterations=10");
    const std::string tile = "/v1/textons/" + id + "/tiles/1/2/3.png?seed=4&mni=30";
    const std::string good = sign(tile);

    EXPECT_EQ(outcome(c, good), "200");
    EXPECT_EQ(outcome(c, tile), "403 signature_missing");
    // The layer's signature opens every tile of it, not another layer or texton.
    auto replace = [](std::string s, const std::string& a, const std::string& b) {
        return s.replace(s.find(a), a.size(), b);
    };
    EXPECT_EQ(outcome(c, replace(good, "/1/2/3.png", "/5/-8/13.png")), "200");
    EXPECT_EQ(outcome(c, replace(good, "/1/2/3.png", "/1/2/3.webp")), "403 signature_invalid");
    EXPECT_EQ(outcome(c, replace(good, id, other)), "403 signature_invalid");
    EXPECT_EQ(outcome(c, replace(good, "/tiles/", "/map/")), "403 signature_invalid");
    // The query: a changed, added or removed field.
    EXPECT_EQ(outcome(c, replace(good, "seed=4", "seed=5")), "403 signature_invalid");
    EXPECT_EQ(outcome(c, replace(good, "mni=30&", "")), "403 signature_invalid");
    EXPECT_EQ(outcome(c, replace(good, "?", "?size=512&")), "403 signature_invalid");
    // The order of the fields does not matter (they are sorted before signing).
    EXPECT_EQ(outcome(c, replace(good, "seed=4&mni=30", "mni=30&seed=4")), "200");
    // The signature itself, and the key.
    std::string flipped = good;
    flipped.back() = flipped.back() == '0' ? '1' : '0';
    EXPECT_EQ(outcome(c, flipped), "403 signature_invalid");
    EXPECT_EQ(outcome(c, http::sign_url("another key of some length", tile, 0).value()),
              "403 signature_invalid");
    // Expiry: a future exp passes, a past one fails, and a changed exp breaks the signature.
    const std::string region = "/v1/textons/" + id + "/region.png?w=32&h=32&seed=1";
    const std::string later = sign(region, now_s() + 3600);
    EXPECT_EQ(outcome(c, later), "200");
    // No cache may keep it past its exp.
    const std::string cc = c.Get(later)->get_header_value("Cache-Control");
    EXPECT_EQ(cc.rfind("public, max-age=", 0), 0u) << cc;
    EXPECT_LE(std::stoll(cc.substr(16)), 3600);
    EXPECT_EQ(cc.find("immutable"), std::string::npos) << cc;
    // An empty signature is no signature that matches.
    EXPECT_EQ(outcome(c, tile + "&sig="), "403 signature_invalid");
    EXPECT_EQ(outcome(c, sign(region, now_s() - 5)), "403 signature_expired");
    const std::string exp_text = "exp=" + std::to_string(now_s() + 3600);
    EXPECT_EQ(outcome(c, replace(later, later.substr(later.find("exp="), exp_text.size()),
                                 "exp=" + std::to_string(now_s() + 7200))),
              "403 signature_invalid");
    // Tileable and spectrum are image URLs too; the list and metadata are not.
    EXPECT_EQ(outcome(c, "/v1/textons/" + id + "/tileable.png?w=32&h=32"), "403 signature_missing");
    EXPECT_EQ(outcome(c, sign("/v1/textons/" + id + "/tileable.png?w=32&h=32")), "200");
    EXPECT_EQ(outcome(c, "/v1/textons/" + id + "/spectrum.png"), "403 signature_missing");
    EXPECT_EQ(outcome(c, "/v1/textons/" + id + "/quality.json"), "403 signature_missing");
    EXPECT_EQ(outcome(c, "/v1/textons/" + id + "/quality.png"), "403 signature_missing");
    auto quality = c.Get(sign("/v1/textons/" + id + "/quality.json?seed=2"));
    ASSERT_TRUE(quality && quality->status == 200);
    const std::string qpng = nlohmann::json::parse(quality->body).at("links").at("png");
    EXPECT_EQ(outcome(c, qpng), "200") << "the report's own link is signed";
    EXPECT_EQ(outcome(c, "/v1/textons/" + id), "200");

    // A signed TileJSON hands out signed templates (with its exp): their tiles open.
    const std::string tj = sign("/v1/textons/" + id + "/tilejson.json?seed=3", now_s() + 600);
    auto r = c.Get(tj);
    ASSERT_TRUE(r && r->status == 200) << (r ? r->body : "no answer");
    std::string tmpl = nlohmann::json::parse(r->body).at("tiles")[0];
    tmpl = tmpl.substr(tmpl.find("/v1/"));
    EXPECT_NE(tmpl.find("sig="), std::string::npos);
    for (const auto& [from, to] : {std::pair{"{z}", "22"}, {"{x}", "-1"}, {"{y}", "7"}})
        tmpl = replace(tmpl, from, to);
    EXPECT_EQ(outcome(c, tmpl), "200") << tmpl;

    // The CLI signs as the server checks.
    const RunResult cli = run("sign '" + tile + "' --key '" + std::string(kKey) + "'");
    ASSERT_EQ(cli.code, 0) << cli.err;
    EXPECT_EQ(cli.out, good + "\n");
    EXPECT_NE(run("sign '" + tile + "'").code, 0) << "no key, no signature";
    EXPECT_NE(run("sign '" + tile + "' --key short").code, 0) << "a key too short to be secret";
}

TEST(SignedUrls, PresetsAreTheOnlyParameterSets) {
    auto config = TestServer::default_config();
    config.presets =
        http::parse_presets(R"({"web-256": {"format": "webp", "quality": 80, "seed": 9},
                                "game": {"format": "png", "seed": 7, "mni": 20}})")
            .value();
    TestServer server(config);
    auto c = server.client();
    const std::string id = upload(c, "etr_sand01.png", "?size=16&iterations=10");
    const std::string base = "/v1/textons/" + id;

    EXPECT_EQ(outcome(c, base + "/tiles/0/0/0.png?seed=7"), "403 preset_required");
    EXPECT_EQ(outcome(c, base + "/tiles/0/0/0.png?preset=print"), "400 unknown_preset");
    EXPECT_EQ(outcome(c, base + "/tiles/0/0/0.png?preset=game&seed=8"), "400 invalid_parameter");
    EXPECT_EQ(outcome(c, base + "/tiles/0/0/0.png?preset=web-256"), "400 invalid_parameter");
    // The preset's tile is the tile of its fields (compared on an unpreset server).
    auto game = c.Get(base + "/tiles/0/1/1.png?preset=game");
    ASSERT_TRUE(game && game->status == 200);
    TestServer plain;
    auto p = plain.client();
    ASSERT_EQ(upload(p, "etr_sand01.png", "?size=16&iterations=10"), id);
    EXPECT_EQ(game->body, p.Get(base + "/tiles/0/1/1.png?seed=7&mni=20")->body);
    EXPECT_NE(game->body, p.Get(base + "/tiles/0/1/1.png?seed=7")->body);
    // Extension-less: the preset's format, whatever Accept says.
    httplib::Headers accept = {{"Accept", "image/avif"}};
    auto web = c.Get(base + "/tiles/0/1/1?preset=web-256", accept);
    ASSERT_TRUE(web && web->status == 200) << (web ? web->body : "");
    EXPECT_EQ(web->get_header_value("Content-Type"), "image/webp");
    EXPECT_EQ(web->body, p.Get(base + "/tiles/0/1/1.webp?seed=9&quality=80")->body);
    // TileJSON names the preset and its format.
    auto tj = c.Get(base + "/tilejson.json?preset=web-256");
    ASSERT_TRUE(tj && tj->status == 200);
    const std::string tmpl = nlohmann::json::parse(tj->body).at("tiles")[0];
    EXPECT_NE(tmpl.find("/map/{z}/{x}/{y}.webp?preset=web-256"), std::string::npos) << tmpl;
    // Bad preset files are refused clearly.
    EXPECT_FALSE(http::parse_presets(R"({"a b": {}})").ok());
    EXPECT_FALSE(http::parse_presets(R"({"x": {"sig": "1"}})").ok());
    EXPECT_FALSE(http::parse_presets(R"([1, 2])").ok());
    EXPECT_FALSE(http::parse_presets(R"({"x": {"format": "gif"}})").ok());
    EXPECT_FALSE(http::parse_presets(R"({"x": {"seed": 1}})").ok()) << "a format each";
    EXPECT_FALSE(http::parse_presets(R"({"x": {"format": "png", "quality": 80}})").ok());
    EXPECT_FALSE(http::parse_presets(R"({"x": {"format": "png", "sed": 1}})").ok());
    EXPECT_FALSE(http::parse_presets(R"({"x": {"format": "png", "seed": 1.5}})").ok());
}

} // namespace
} // namespace textond::test
