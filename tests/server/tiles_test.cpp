// Images over HTTP: tiles stitch into the region of the same window (near the origin, at negative
// and at huge indices, at several levels), map tiles are level tiles, TileJSON points at them,
// tileable textures wrap, and the caching headers (ETag, 304, Cache-Control, CORS, HEAD) hold.
#include "server/app/quality_report.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <set>

#include <chrono>
#include <cmath>
#include <thread>

namespace textond::test {
namespace {

using nlohmann::json;

class Tiles : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        server = new TestServer();
        auto c = server->client();
        id = upload(c, "etr_pebbles04.png", "?size=32&iterations=20");
    }
    static void TearDownTestSuite() {
        delete server;
        server = nullptr;
    }
    static core::Image get_image(const std::string& path) {
        auto c = server->client();
        auto res = c.Get(path.c_str());
        if (!res || res->status != 200) {
            ADD_FAILURE() << path << ": "
                          << (res ? std::to_string(res->status) + " " + res->body : "no response");
            return {};
        }
        return decode(res->body);
    }
    static core::Image stitch(const std::vector<core::Image>& tiles) {
        const int s = tiles[0].width;
        core::Image out(2 * s, 2 * s, tiles[0].channels);
        for (int t = 0; t < 4; ++t)
            for (int c = 0; c < out.channels; ++c)
                for (int y = 0; y < s; ++y)
                    for (int x = 0; x < s; ++x)
                        out.at(c, (t % 2) * s + x, (t / 2) * s + y) = tiles[t].at(c, x, y);
        return out;
    }
    static inline TestServer* server = nullptr;
    static inline std::string id;
};

TEST_F(Tiles, FourTilesEqualTheRegionOfTheSameWindow) {
    ASSERT_FALSE(id.empty());
    struct Case {
        int z;
        long long x, y;
        const char* ext;
    };
    const long long big = (1LL << 53) + 12345; // beyond float precision, still on the plane
    for (const Case& k : {Case{0, 0, 0, "png"}, Case{0, -1, -1, "exr"}, Case{0, -7, 3, "png16"},
                          Case{0, big, -big, "exr"}, Case{2, -3, 5, "exr"}, Case{-2, 11, -4, "png"},
                          Case{9, 40, -40, "exr"}}) {
        SCOPED_TRACE(std::string("z=") + std::to_string(k.z) + " x=" + std::to_string(k.x) +
                     " y=" + std::to_string(k.y) + " " + k.ext);
        std::vector<core::Image> tiles;
        for (int t = 0; t < 4; ++t)
            tiles.push_back(get_image("/v1/textons/" + id + "/tiles/" + std::to_string(k.z) + "/" +
                                      std::to_string(k.x + t % 2) + "/" +
                                      std::to_string(k.y + t / 2) + "." + k.ext + "?seed=9"));
        ASSERT_EQ(tiles[0].width, 256);
        const core::Image region =
            get_image("/v1/textons/" + id + "/region." + k.ext +
                      "?seed=9&w=512&h=512&z=" + std::to_string(k.z) +
                      "&x=" + std::to_string(k.x * 256) + "&y=" + std::to_string(k.y * 256));
        ASSERT_EQ(region.width, 512);
        EXPECT_EQ(max_abs_diff(stitch(tiles), region), 0.0);
        // Not a constant: the comparison above could not pass by accident.
        EXPECT_GT(moments(region.plane(0), region.plane_size()).variance, 1e-5);
    }
}

TEST_F(Tiles, SeedsAndSizesChangeTheImage) {
    const core::Image a = get_image("/v1/textons/" + id + "/tiles/0/0/0.exr?seed=1");
    const core::Image b = get_image("/v1/textons/" + id + "/tiles/0/0/0.exr?seed=2");
    EXPECT_GT(max_abs_diff(a, b), 0.01);
    const core::Image big = get_image("/v1/textons/" + id + "/tiles/0/0/0.exr?seed=1&size=512");
    EXPECT_EQ(big.width, 512);
    EXPECT_EQ(max_abs_diff(test::crop(big, 256, 256), a), 0.0);
}

// marginals=exemplar over HTTP: offered by the texton, its tiles stitch into its region, differ
// from the Gaussian ones (another ETag), TileJSON carries it into its tile URLs, and a bad value,
// a mix or a tileable texture asking for it get plain answers.
TEST_F(Tiles, ExemplarMarginalsTilesStitchAndTileJsonCarriesThem) {
    auto c = server->client();
    auto meta = c.Get(("/v1/textons/" + id).c_str());
    ASSERT_TRUE(meta && meta->status == 200);
    EXPECT_EQ(json::parse(meta->body).at("marginals"), json({"gaussian", "exemplar"}));
    const std::string q = "?seed=3&marginals=exemplar";
    std::vector<core::Image> tiles;
    for (int t = 0; t < 4; ++t)
        tiles.push_back(get_image("/v1/textons/" + id + "/tiles/1/" + std::to_string(t % 2 - 1) +
                                  "/" + std::to_string(t / 2) + ".exr" + q));
    const core::Image region =
        get_image("/v1/textons/" + id + "/region.exr" + q + "&w=512&h=512&z=1&x=-256&y=0");
    EXPECT_EQ(max_abs_diff(stitch(tiles), region), 0.0);
    const core::Image gauss = get_image("/v1/textons/" + id + "/tiles/1/-1/0.exr?seed=3");
    EXPECT_GT(max_abs_diff(gauss, tiles[0]), 0.005);
    auto e1 = c.Get(("/v1/textons/" + id + "/tiles/1/-1/0.png?seed=3").c_str());
    auto e2 = c.Get(("/v1/textons/" + id + "/tiles/1/-1/0.png" + q).c_str());
    ASSERT_TRUE(e1 && e2);
    EXPECT_NE(e1->get_header_value("ETag"), e2->get_header_value("ETag"));
    auto tj = c.Get(("/v1/textons/" + id + "/tilejson.json" + q).c_str());
    ASSERT_TRUE(tj && tj->status == 200);
    const json j = json::parse(tj->body);
    EXPECT_NE(j.at("tiles")[0].get<std::string>().find("&marginals=exemplar"), std::string::npos);
    EXPECT_EQ(j.at("textond").at("marginals"), "exemplar");
    for (const std::string& bad : {"/v1/textons/" + id + "/tiles/0/0/0.png?marginals=histogram",
                                   "/v1/textons/" + id + "/region.png?marginals=1"}) {
        auto r = c.Get(bad.c_str());
        ASSERT_TRUE(r);
        EXPECT_EQ(r->status, 400) << bad;
        EXPECT_NE(r->body.find("gaussian or exemplar"), std::string::npos) << r->body;
    }
    auto tileable =
        c.Get(("/v1/textons/" + id + "/tileable.png?w=64&h=64&marginals=exemplar").c_str());
    ASSERT_TRUE(tileable);
    EXPECT_EQ(tileable->status, 200); // tileable textures restore too
}

// The quality report: the texton's numbers, histograms that are distributions, restoration
// bringing the noise's marginals closer to the exemplar's, and the picture its link names.
TEST_F(Tiles, QualityReportHasTheNumbersHistogramsAndItsPicture) {
    auto c = server->client();
    auto meta = c.Get(("/v1/textons/" + id).c_str());
    auto res = c.Get(("/v1/textons/" + id + "/quality.json?seed=5").c_str());
    ASSERT_TRUE(meta && res);
    ASSERT_EQ(res->status, 200) << res->body;
    const json m = json::parse(meta->body), q = json::parse(res->body);
    EXPECT_EQ(q.at("rme"), m.at("rme"));
    EXPECT_EQ(q.at("kind"), m.at("kind"));
    EXPECT_EQ(q.at("verdict"), "micro-texture: the noise keeps its look"); // pebbles
    for (const char* which : {"exemplar", "gaussian", "restored"}) {
        const auto& h = q.at("histograms").at(which);
        ASSERT_EQ(h.size(), 3u) << which;
        for (const auto& channel : h) {
            double sum = 0;
            for (double v : channel) sum += v;
            EXPECT_NEAR(sum, 1.0, 1e-9) << which;
        }
    }
    const double wg = q.at("wasserstein").at("gaussian"), wr = q.at("wasserstein").at("restored");
    EXPECT_LT(wr, wg);
    const core::Image png = get_image(q.at("links").at("png").get<std::string>());
    const int w = q.at("window").at("width"), h = q.at("window").at("height");
    EXPECT_EQ(png.width, 3 * w + 8);
    EXPECT_EQ(png.height, 2 * h + 96 + 8);
    EXPECT_EQ(c.Get(("/v1/textons/" + id + "/quality.json?mni=0").c_str())->status, 400);
    EXPECT_EQ(c.Get(("/v1/textons/" + std::string(64, 'b') + "/quality.png").c_str())->status, 404);
}

TEST_F(Tiles, MapTilesAreLevelTilesAndTileJsonPointsAtThem) {
    auto c = server->client();
    auto res = c.Get(("/v1/textons/" + id + "/tilejson.json?seed=4&mni=20").c_str());
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << res->body;
    EXPECT_EQ(res->get_header_value("Vary"), "Host");
    const json tj = json::parse(res->body);
    EXPECT_EQ(tj.at("tilejson"), "3.0.0");
    EXPECT_EQ(tj.at("scheme"), "xyz");
    EXPECT_LT(tj.at("minzoom").get<int>(), tj.at("maxzoom").get<int>());
    std::string url = tj.at("tiles").at(0);
    const std::string base = "http://127.0.0.1:" + std::to_string(server->port());
    ASSERT_EQ(url.rfind(base, 0), 0u) << url; // absolute
    // Fill the template as a map client would at zoom 23 (one level coarser than native).
    for (auto [key, value] : {std::pair{"{z}", "23"}, {"{x}", "-2"}, {"{y}", "1"}})
        url.replace(url.find(key), std::string(key).size(), value);
    const core::Image map_tile = get_image(url.substr(base.size()));
    const core::Image level_tile =
        get_image("/v1/textons/" + id + "/tiles/1/-2/1.png?seed=4&mni=20");
    EXPECT_EQ(max_abs_diff(map_tile, level_tile), 0.0);
    // A larger client zoom shows more detail: zoom 24 is level 0, whose 2x2 box average is level 1.
    const core::Image fine =
        get_image("/v1/textons/" + id + "/region.exr?seed=4&mni=20&w=512&h=512&x=-1024&y=512");
    const core::Image coarse =
        get_image("/v1/textons/" + id + "/region.exr?seed=4&mni=20&w=256&h=256&z=1&x=-512&y=256");
    double worst = 0;
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x) {
            const double avg = (fine.at(0, 2 * x, 2 * y) + fine.at(0, 2 * x + 1, 2 * y) +
                                fine.at(0, 2 * x, 2 * y + 1) + fine.at(0, 2 * x + 1, 2 * y + 1)) /
                               4;
            worst = std::max(worst, std::abs(avg - coarse.at(0, x, y)));
        }
    EXPECT_LT(worst, 1e-4);
}

// Mean square of the jump across the wrap-around edges (left/right and top/bottom) over the mean
// square of the jumps between neighbouring pixels inside: about 1 for a texture that wraps, about
// 2 (two independent values) for an ordinary window, so the test can fail.
double wrap_ratio(const core::Image& im) {
    double inside = 0, wrap = 0;
    long long n_inside = 0, n_wrap = 0;
    for (int c = 0; c < im.channels; ++c)
        for (int y = 0; y < im.height; ++y)
            for (int x = 0; x < im.width; ++x) {
                const int xr = (x + 1) % im.width, yd = (y + 1) % im.height;
                const double dx = im.at(c, xr, y) - im.at(c, x, y);
                const double dy = im.at(c, x, yd) - im.at(c, x, y);
                (xr == 0 ? wrap : inside) += dx * dx;
                (xr == 0 ? n_wrap : n_inside) += 1;
                (yd == 0 ? wrap : inside) += dy * dy;
                (yd == 0 ? n_wrap : n_inside) += 1;
            }
    return (wrap / static_cast<double>(n_wrap)) / (inside / static_cast<double>(n_inside));
}

TEST_F(Tiles, TileableTexturesWrapAtAnySize) {
    // Cell side a = 20 for r = 32: 400 x 300 is 20 x 15 cells exactly; the others are
    // resampled by their Fourier series.
    for (auto [w, h] : {std::pair{400, 300}, std::pair{515, 389}, std::pair{257, 700}}) {
        SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
        const core::Image t =
            get_image("/v1/textons/" + id + "/tileable.exr?w=" + std::to_string(w) +
                      "&h=" + std::to_string(h) + "&seed=3");
        ASSERT_EQ(t.width, w);
        ASSERT_EQ(t.height, h);
        // Neighbour differences decorrelate within a few pixels, so the w + h edge jumps are
        // worth at least (w + h) / 4 independent squares: relative sd <= sqrt(8 / (w + h)).
        // 6 / sqrt(w + h) is over 2 of those sds.
        const double bound = 6.0 / std::sqrt(static_cast<double>(w + h));
        EXPECT_NEAR(wrap_ratio(t), 1.0, bound);
    }
    const core::Image plain = get_image("/v1/textons/" + id + "/region.exr?w=400&h=300&seed=3");
    EXPECT_GT(wrap_ratio(plain), 1.6);
}

TEST_F(Tiles, ExemplarIsKeptAndItsSpectrumMatchesTheNoises) {
    // The stored exemplar is the uploaded pixels (an 8-bit RGB PNG round-trips exactly).
    const core::Image stored = get_image("/v1/textons/" + id + "/exemplar.png");
    EXPECT_EQ(max_abs_diff(stored, load_exemplar("etr_pebbles04.png")), 0.0);

    const core::Image s = get_image("/v1/textons/" + id + "/spectrum.png?seed=5");
    const int w = 256, h = 256, gap = 4;
    ASSERT_EQ(s.width, 2 * w + gap);
    ASSERT_EQ(s.height, h);
    // Radial profiles of the two log spectra (exemplar | noise): a Gaussian model reproduces
    // the exemplar's spectrum, so the profiles agree (the bins average hundreds of values each).
    std::vector<double> a(w / 2, 0), b(w / 2, 0), n(w / 2, 0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const int r = static_cast<int>(std::hypot(x - w / 2, y - h / 2));
            if (r < 1 || r >= w / 2) continue;
            a[r] += s.at(0, x, y);
            b[r] += s.at(0, w + gap + x, y);
            n[r] += 1;
        }
    double ma = 0, mb = 0, k = 0;
    for (int r = 1; r < w / 2; ++r) {
        a[r] /= n[r];
        b[r] /= n[r];
        ma += a[r];
        mb += b[r];
        k += 1;
    }
    ma /= k;
    mb /= k;
    double sab = 0, saa = 0, sbb = 0, worst = 0;
    for (int r = 1; r < w / 2; ++r) {
        sab += (a[r] - ma) * (b[r] - mb);
        saa += (a[r] - ma) * (a[r] - ma);
        sbb += (b[r] - mb) * (b[r] - mb);
        worst = std::max(worst, std::abs(a[r] - b[r]));
    }
    EXPECT_GT(sab / std::sqrt(saa * sbb), 0.9);
    EXPECT_LT(worst, 0.15); // 0.15 of 5 decades: within a factor 5.6 at every radius
    // Cached and immutable like every image.
    auto c = server->client();
    auto again = c.Get(("/v1/textons/" + id + "/spectrum.png?seed=5").c_str());
    EXPECT_EQ(again->get_header_value("Cache-Control"), "public, max-age=31536000, immutable");
    EXPECT_EQ(c.Get(("/v1/textons/" + id + "/spectrum.png?size=3").c_str())->status, 400);
}

TEST_F(Tiles, EtagNotModifiedCacheHeadersCorsAndHead) {
    auto c = server->client();
    const std::string path = "/v1/textons/" + id + "/tiles/3/-5/8.png?seed=12";
    auto first = c.Get(path.c_str());
    ASSERT_TRUE(first);
    ASSERT_EQ(first->status, 200);
    const std::string etag = first->get_header_value("ETag");
    ASSERT_GE(etag.size(), 3u);
    EXPECT_EQ(etag.front(), '"'); // strong
    EXPECT_EQ(first->get_header_value("Cache-Control"), "public, max-age=31536000, immutable");
    EXPECT_EQ(first->get_header_value("Content-Type"), "image/png");
    EXPECT_EQ(first->get_header_value("Access-Control-Allow-Origin"), "*");
    EXPECT_FALSE(first->has_header("Vary"));
    EXPECT_FALSE(first->get_header_value("X-Request-Id").empty());

    auto second = c.Get(path.c_str()); // from the cache: same bytes, same tag
    ASSERT_TRUE(second);
    EXPECT_EQ(second->body, first->body);
    EXPECT_EQ(second->get_header_value("ETag"), etag);

    for (const std::string& inm : {etag, "\"nope\", " + etag, std::string("*"), "W/" + etag}) {
        auto nm = c.Get(path.c_str(), {{"If-None-Match", inm}});
        ASSERT_TRUE(nm);
        EXPECT_EQ(nm->status, 304) << inm;
        EXPECT_TRUE(nm->body.empty());
        EXPECT_EQ(nm->get_header_value("ETag"), etag);
    }
    EXPECT_EQ(c.Get(path.c_str(), {{"If-None-Match", "\"other\""}})->status, 200);
    // If-Match (RFC 9110 13.1.1): the image only when the tag names it, by the strong comparison.
    for (const std::string& im : {etag, "\"nope\", " + etag, std::string("*")}) {
        auto m = c.Get(path.c_str(), {{"If-Match", im}});
        ASSERT_TRUE(m);
        EXPECT_EQ(m->status, 200) << im;
        EXPECT_EQ(m->body, first->body) << im;
    }
    for (const std::string& im : {std::string("\"other\""), "W/" + etag}) {
        auto m = c.Get(path.c_str(), {{"If-Match", im}});
        ASSERT_TRUE(m);
        EXPECT_EQ(m->status, 412) << im;
        EXPECT_EQ(nlohmann::json::parse(m->body)["error"]["code"], "precondition_failed");
    }
    // Another seed is another image with another tag.
    auto other = c.Get(("/v1/textons/" + id + "/tiles/3/-5/8.png?seed=13").c_str());
    EXPECT_NE(other->get_header_value("ETag"), etag);

    auto head = c.Head(path.c_str());
    ASSERT_TRUE(head);
    EXPECT_EQ(head->status, 200);
    EXPECT_TRUE(head->body.empty());
    EXPECT_EQ(head->get_header_value("Content-Length"), std::to_string(first->body.size()));
    EXPECT_EQ(head->get_header_value("ETag"), etag);

    auto pre = c.Options(path.c_str(), {{"Origin", "https://game.example"},
                                        {"Access-Control-Request-Method", "GET"}});
    ASSERT_TRUE(pre);
    EXPECT_EQ(pre->status, 204);
    EXPECT_EQ(pre->get_header_value("Access-Control-Allow-Origin"), "*");
    EXPECT_NE(pre->get_header_value("Access-Control-Allow-Methods").find("GET"), std::string::npos);

    // What a DELETE takes away is not kept by caches (metadata, TileJSON, the list) or only for
    // a minute (exemplar, texton files); the noise images are content-addressed, immutable.
    auto cache_control = [&](const std::string& url) {
        return c.Get(url.c_str())->get_header_value("Cache-Control");
    };
    const std::string base = "/v1/textons/" + id;
    EXPECT_EQ(cache_control(base + "/tilejson.json"), "no-cache");
    EXPECT_EQ(cache_control(base), "no-cache");
    EXPECT_EQ(cache_control("/v1/textons"), "no-cache");
    for (const char* file : {"/exemplar.png", "/texton.png", "/texton.exr", "/texton.texton"})
        EXPECT_EQ(cache_control(base + file), "no-cache") << file;
    EXPECT_EQ(cache_control(base + "/kit.tar"), "no-cache");
    EXPECT_EQ(cache_control(base + "/tiles/0/0/0.png"), "public, max-age=31536000, immutable");
}

// HEAD says what GET says: cpp-httplib added Accept-Ranges to HEAD answers alone, so a client or
// an edge (nginx serves ranges of a cached answer only when its upstream says so) saw byte
// ranges on one method and not the other. Successes take ranges; errors are answered whole.
TEST_F(Tiles, HeadAndGetSayTheSameHeaders) {
    auto c = server->client();
    for (const auto& [path, status] : std::vector<std::pair<std::string, int>>{
             {"/v1/textons/" + id + "/tiles/0/1/2.png", 200},
             {"/v1/textons/" + id + "/texton.exr", 200},
             {"/v1/textons/" + std::string(64, 'f') + "/tiles/0/1/2.png", 404},
             {"/v1/textons/nope", 400}}) {
        SCOPED_TRACE(path);
        auto get = c.Get(path.c_str());
        auto head = c.Head(path.c_str());
        ASSERT_TRUE(get && head);
        EXPECT_EQ(get->status, status);
        EXPECT_EQ(head->status, status);
        std::set<std::string> got, headed;
        for (const auto& [name, value] : get->headers) got.insert(name);
        for (const auto& [name, value] : head->headers) headed.insert(name);
        EXPECT_EQ(got, headed);
        EXPECT_EQ(get->get_header_value_count("Accept-Ranges"), 1u);
        EXPECT_EQ(head->get_header_value_count("Accept-Ranges"), 1u);
        EXPECT_EQ(get->get_header_value("Accept-Ranges"), status == 200 ? "bytes" : "none");
        EXPECT_EQ(head->get_header_value("Accept-Ranges"), get->get_header_value("Accept-Ranges"));
    }
    // A JSON answer is always whole, and says so.
    for (const std::string& path : std::vector<std::string>{"/v1/textons/" + id, "/healthz"}) {
        auto get = c.Get(path.c_str(), {{"Range", "bytes=0-9"}});
        ASSERT_TRUE(get);
        EXPECT_EQ(get->status, 200) << path;
        EXPECT_EQ(get->get_header_value("Accept-Ranges"), "none") << path;
    }
}

TEST(TilesCors, ListedOriginsAreEchoedWithVary) {
    http::ServeConfig config = TestServer::default_config();
    config.cors_origin = "https://a.example, https://b.example";
    TestServer server(config);
    auto c = server.client();
    auto ok = c.Get("/healthz", {{"Origin", "https://b.example"}});
    EXPECT_EQ(ok->get_header_value("Access-Control-Allow-Origin"), "https://b.example");
    EXPECT_EQ(ok->get_header_value("Vary"), "Origin");
    auto no = c.Get("/healthz", {{"Origin", "https://evil.example"}});
    EXPECT_FALSE(no->has_header("Access-Control-Allow-Origin"));
}

TEST(Ops, HealthReadinessMetricsAndSpec) {
    TestServer server;
    auto c = server.client();
    auto h = c.Get("/healthz");
    ASSERT_TRUE(h);
    EXPECT_EQ(h->status, 200);
    EXPECT_EQ(json::parse(h->body).at("status"), "ok");
    auto r = c.Get("/readyz");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 200) << r->body;
    EXPECT_EQ(json::parse(r->body).at("backend").at("name"), "cpu");
    const std::string id = upload(c, "etr_sand01.png", "?size=16&iterations=5");
    c.Get(("/v1/textons/" + id + "/tiles/0/0/0.png").c_str());
    c.Get(("/v1/textons/" + id + "/tiles/0/0/0.png").c_str());
    // A request is counted after its response is written, so the last one can land a moment
    // after the client has its answer: poll briefly.
    const std::vector<std::string> series = {
        "textond_http_requests_total{route=\"/v1/textons/{id}/tiles/{z}/{x}/{y}.{format}\","
        "method=\"GET\",status=\"200\"} 2",
        "textond_http_request_duration_seconds_bucket{route=\"/v1/textons\",status=\"201\","
        "le=\"+Inf\"} 1",
        "textond_tile_cache_requests_total{result=\"hit\"} 1",
        "textond_tile_cache_requests_total{result=\"miss\"} 1",
        "textond_render_seconds_count{backend=\"cpu\",kind=\"tile\"} 1",
        // One cold tile went through every stage; both answers were sent.
        "textond_image_stage_seconds_count{stage=\"queue\"} 1",
        "textond_image_stage_seconds_count{stage=\"render\"} 1",
        "textond_image_stage_seconds_count{stage=\"encode\"} 1",
        "textond_image_stage_seconds_count{stage=\"send\"} 2",
        "textond_backend_info{tiles=\"cpu\",frames=\"cpu\"} 1",
        "textond_abandoned_total{reason=\"gone\"} 0", "textond_analyses_total{result=\"ok\"} 1",
        "textond_analysis_queue_depth 0", "textond_store_textons 1"};
    std::string metrics;
    for (int attempt = 0; attempt < 100; ++attempt) {
        auto m = c.Get("/metrics");
        ASSERT_TRUE(m);
        metrics = m->body;
        bool all = true;
        for (const auto& s : series) all = all && metrics.find(s) != std::string::npos;
        if (all) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    for (const auto& s : series)
        EXPECT_NE(metrics.find(s), std::string::npos) << s << "\n" << metrics;
    auto spec = c.Get("/v1/openapi.yaml");
    ASSERT_TRUE(spec);
    EXPECT_EQ(spec->body.rfind("openapi: 3.1", 0), 0u);
    EXPECT_NE(spec->body.find("/v1/textons/{id}/tiles/{z}/{x}/{y}.{format}"), std::string::npos);
}

// A method the client made up is counted under "other": one series, not one a request.
TEST(Ops, MadeUpMethodsShareOneMetricsSeries) {
    TestServer server;
    auto c = server.client();
    for (int k = 0; k < 3; ++k) {
        httplib::Request req;
        req.method = "K" + std::to_string(k) + std::string(200, 'Z');
        req.path = "/healthz";
        auto r = c.send(req);
        ASSERT_TRUE(r);
        EXPECT_GE(r->status, 400);
    }
    std::string metrics;
    for (int attempt = 0; attempt < 100; ++attempt) {
        metrics = c.Get("/metrics")->body;
        if (metrics.find("method=\"other\",status=\"400\"} 3") != std::string::npos) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_EQ(metrics.find("ZZZZ"), std::string::npos);
    EXPECT_NE(metrics.find("method=\"other\",status=\"400\"} 3"), std::string::npos) << metrics;
}

} // namespace
} // namespace textond::test

// The quality report and the page say each verdict in words, and "keeps its look" only under
// micro with an RME that does not say the texton misses its model.
TEST(QualityVerdict, SaysEachKindInWordsAndKeepsItsLookOnlyUnderMicroCloseToItsModel) {
    textond::api::TextonMeta m;
    EXPECT_NE(m.verdict().find("not measured"), std::string::npos);
    m.rme = 0.5;
    m.phase_coherence = 0.01; // an older file: the kind from phase coherence
    EXPECT_EQ(m.kind(), "micro");
    EXPECT_NE(m.verdict().find("keeps its look"), std::string::npos);
    const double band = textond::core::kShapeBand;
    m.shape_score = -band - 1.0; // the shape score decides when present
    EXPECT_NE(m.verdict().find("keeps its look"), std::string::npos);
    m.shape_score = 0.0;
    EXPECT_NE(m.verdict().find("borderline"), std::string::npos);
    EXPECT_NE(m.verdict().find("repeated motifs"), std::string::npos);
    m.shape_score = band + 1.0;
    EXPECT_EQ(m.kind(), "macro");
    EXPECT_NE(m.verdict().find("lose its shapes"), std::string::npos);
    for (double score : {-band - 1.0, 0.0, band + 1.0}) {
        m.shape_score = score;
        m.rme = textond::core::kMissedModelRme + 0.001;
        EXPECT_EQ(m.verdict().find("keeps"), std::string::npos) << score; // no look kept
        EXPECT_NE(m.verdict().find("above 0.8467"), std::string::npos) << score;
        EXPECT_NE(m.verdict().find("misses its model"), std::string::npos) << score;
        m.rme = textond::core::kMissedModelRme - 0.01;
        EXPECT_EQ(m.verdict().find("misses its model"), std::string::npos) << score;
    }
}
