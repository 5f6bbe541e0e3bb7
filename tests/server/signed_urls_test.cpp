// Signed URLs and presets (server/app/url_signing.h) over HTTP: with a signing key a
// good signature gets 200 and a missing one, a tampered path, query, signature or expiry each a
// 403 with its code; one signature opens a whole tile layer, and a signed TileJSON hands out
// signed templates; `textond sign` signs as the server checks, and so does POST /v1/sign for the
// API key's holder. With presets, URLs name one and carry nothing else, and get the preset's tile.
#include "server/app/url_signing.h"
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
    return app::sign_url(kKey, url, exp).value();
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
    EXPECT_EQ(outcome(c, app::sign_url("another key of some length", tile, 0).value()),
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

// POST /v1/sign: the server signs for the holder of its API key (the page uses it), for nobody
// when it has no API key, and hands URLs back as they are when it does not sign.
TEST(SignedUrls, TheServerSignsForItsApiKeyHolderOnly) {
    auto config = TestServer::default_config();
    config.url_signing_key = kKey;
    config.api_key = "the api key";
    TestServer server(config);
    auto c = server.client();
    const httplib::Headers key = {{"Authorization", "Bearer the api key"}};
    auto up = c.Post("/v1/textons?size=16&iterations=10", key,
                     read_file(exemplar_path("etr_sand01.png")), "image/png");
    ASSERT_TRUE(up && up->status == 201);
    const std::string id = nlohmann::json::parse(up->body).at("id");
    const std::string tile = "/v1/textons/" + id + "/map/24/3/4.png?seed=2";
    const std::string body = nlohmann::json{{"urls", {tile}}, {"expires_in", 600}}.dump();

    auto code = [](const httplib::Result& r) {
        return r ? std::to_string(r->status) + " " +
                       nlohmann::json::parse(r->body).at("error").at("code").get<std::string>()
                 : "no answer";
    };
    EXPECT_EQ(code(c.Post("/v1/sign", body, "application/json")), "401 unauthorized");
    EXPECT_EQ(
        code(c.Post("/v1/sign", {{"Authorization", "Bearer guess"}}, body, "application/json")),
        "401 unauthorized");
    const std::int64_t before = now_s();
    auto r = c.Post("/v1/sign", key, body, "application/json");
    ASSERT_TRUE(r && r->status == 200) << (r ? r->body : "no answer");
    const auto j = nlohmann::json::parse(r->body);
    EXPECT_TRUE(j.at("signed").get<bool>());
    EXPECT_GE(j.at("exp").get<std::int64_t>(), before + 600);
    EXPECT_LE(j.at("exp").get<std::int64_t>(), now_s() + 600);
    const std::string signed_tile = j.at("urls")[0];
    EXPECT_EQ(signed_tile, sign(tile, j.at("exp").get<std::int64_t>())) << "as `textond sign`";
    EXPECT_EQ(outcome(c, signed_tile), "200");
    std::string tampered = signed_tile;
    tampered.replace(tampered.find("seed=2"), 6, "seed=3");
    EXPECT_EQ(outcome(c, tampered), "403 signature_invalid");

    for (const std::string& bad :
         {std::string("not json"), std::string(R"({"urls": []})"),
          std::string(R"({"urls": ["/v1/a"], "expires_in": 0})"),
          std::string(R"({"urls": ["/v1/a"], "expires_in": 1.5})"),
          std::string(R"({"urls": ["/v1/a"], "other": 1})"), std::string(R"({"urls": [7]})"),
          std::string(R"({"urls": ["no-slash"]})"),
          nlohmann::json{{"urls", std::vector<std::string>(101, "/v1/a")}}.dump(),
          nlohmann::json{{"urls", {std::string(5000, 'a')}}}.dump()})
        EXPECT_EQ(code(c.Post("/v1/sign", key, bad, "application/json")), "400 invalid_body")
            << bad.substr(0, 60);

    // A signing server without an API key signs for nobody; a server that does not sign hands
    // the URLs back.
    auto no_key = TestServer::default_config();
    no_key.url_signing_key = kKey;
    TestServer keyless(no_key);
    auto k = keyless.client();
    EXPECT_EQ(code(k.Post("/v1/sign", body, "application/json")), "403 signing_unavailable");
    TestServer plain(TestServer::default_config());
    auto p = plain.client();
    r = p.Post("/v1/sign", body, "application/json");
    ASSERT_TRUE(r && r->status == 200);
    EXPECT_EQ(nlohmann::json::parse(r->body),
              (nlohmann::json{{"urls", {tile}}, {"signed", false}}));
}

TEST(SignedUrls, PresetsAreTheOnlyParameterSets) {
    auto config = TestServer::default_config();
    config.presets = app::parse_presets(R"({"web-256": {"format": "webp", "quality": 80, "seed": 9},
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
    // A preset's 30.0 is mni=30 (the canonical spelling), not a refusal at start.
    EXPECT_TRUE(app::parse_presets(R"({"x": {"format": "png", "mni": 30.0}})").ok());
    // Bad preset files are refused clearly.
    EXPECT_FALSE(app::parse_presets(R"({"a b": {}})").ok());
    EXPECT_FALSE(app::parse_presets(R"({"x": {"sig": "1"}})").ok());
    EXPECT_FALSE(app::parse_presets(R"([1, 2])").ok());
    EXPECT_FALSE(app::parse_presets(R"({"x": {"format": "gif"}})").ok());
    EXPECT_FALSE(app::parse_presets(R"({"x": {"seed": 1}})").ok()) << "a format each";
    EXPECT_FALSE(app::parse_presets(R"({"x": {"format": "png", "quality": 80}})").ok());
    EXPECT_FALSE(app::parse_presets(R"({"x": {"format": "png", "sed": 1}})").ok());
    EXPECT_FALSE(app::parse_presets(R"({"x": {"format": "png", "seed": 1.5}})").ok());
}

// The engine kit is an image route like the others: signed, preset and rate limited, and
// cached (kit.tar used to be served unsigned, without a preset and past the rate, and built
// anew each time: 0.4 s of CPU per distinct mni).
TEST(SignedUrls, TheEngineKitIsSignedPresetRateLimitedAndCached) {
    auto config = TestServer::default_config();
    config.url_signing_key = kKey;
    config.render_rate = 1; // a minute
    config.render_burst = 2;
    TestServer server(config);
    auto c = server.client();
    const std::string kit =
        "/v1/textons/" + upload(c, "etr_sand01.png", "?size=16&iterations=10") + "/kit.tar";
    EXPECT_EQ(outcome(c, kit + "?mni=20"), "403 signature_missing");
    EXPECT_EQ(outcome(c, sign(kit + "?mni=20")), "200");
    EXPECT_EQ(outcome(c, sign(kit + "?mni=21")), "200");
    // The burst is spent: a third kit is a render too many, the first again is cached.
    EXPECT_EQ(outcome(c, sign(kit + "?mni=22")), "429 rate_limited");
    for (int i = 0; i < 3; ++i) EXPECT_EQ(outcome(c, sign(kit + "?mni=20")), "200") << i;

    auto presets = TestServer::default_config();
    presets.presets = app::parse_presets(R"({"game": {"format": "png", "mni": 20}})").value();
    TestServer with_presets(presets);
    auto p = with_presets.client();
    const std::string pkit =
        "/v1/textons/" + upload(p, "etr_sand01.png", "?size=16&iterations=10") + "/kit.tar";
    EXPECT_EQ(outcome(p, pkit), "403 preset_required");
    EXPECT_EQ(outcome(p, pkit + "?mni=20"), "403 preset_required");
    auto game = p.Get(pkit + "?preset=game");
    ASSERT_TRUE(game && game->status == 200);
    TestServer plain;
    auto u = plain.client();
    upload(u, "etr_sand01.png", "?size=16&iterations=10");
    EXPECT_EQ(game->body, u.Get(pkit + "?mni=20")->body) << "the preset's density";
}

} // namespace
} // namespace textond::test
