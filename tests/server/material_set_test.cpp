// Material sets over HTTP: a multipart upload of albedo and height (etr_pebbles04's RGB and its
// luminance as a 16-bit PNG), the metadata's maps, map tiles, normal tiles stitched into their
// region, and the refusals.
#include "api/requests.h"
#include "core/elevation_encoding.h"
#include "server/io/image_io.h"
#include "server/io/mbtiles.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <tuple>
#include <vector>

namespace textond::test {
namespace {

using nlohmann::json;

std::string height_png16(const core::Image& u, int width) {
    core::Image h(width, u.height, 1);
    for (int y = 0; y < u.height; ++y)
        for (int x = 0; x < width; ++x)
            h.at(0, x, y) = (u.at(0, x, y) + u.at(1, x, y) + u.at(2, x, y)) / 3.0f;
    return io::encode_image_memory(h, io::Encoding::png16).value();
}

// The pebble set (albedo: the photo; height: its luminance, 16-bit) uploaded: its texton's path,
// "" (and a failure) when the upload fails.
std::string upload_pebble_set(httplib::Client& c) {
    const core::Image u = load_exemplar("etr_pebbles04.png");
    httplib::MultipartFormDataItems form = {
        {"albedo", read_file(exemplar_path("etr_pebbles04.png")), "a.png", "image/png"},
        {"height", height_png16(u, u.width), "h.png", "image/png"},
        {"size", "16", "", ""},
        {"iterations", "20", "", ""}};
    auto up = c.Post("/v1/textons", form);
    EXPECT_TRUE(up && up->status == 201) << (up ? up->body : "no answer");
    if (!up || up->status != 201) return "";
    return "/v1/textons/" + json::parse(up->body).at("id").get<std::string>();
}

core::Image decoded(const httplib::Result& r) {
    EXPECT_TRUE(r);
    EXPECT_EQ(r->status, 200) << r->body;
    return io::decode_image_memory(r->body).value();
}

TEST(MaterialSet, UploadListsTheMapsAndServesEachAlignedAndNormalsSeamless) {
    TestServer server;
    auto c = server.client();
    const std::string albedo = read_file(exemplar_path("etr_pebbles04.png"));
    const core::Image u = load_exemplar("etr_pebbles04.png");
    httplib::MultipartFormDataItems form = {
        {"height", height_png16(u, u.width), "h.png", "image/png"},
        {"albedo", albedo, "a.png", "image/png"},
        {"size", "16", "", ""},
        {"iterations", "20", "", ""}};
    auto up = c.Post("/v1/textons", form);
    ASSERT_TRUE(up);
    ASSERT_EQ(up->status, 201) << up->body;
    const json meta = json::parse(up->body);
    const std::string id = meta.at("id");
    EXPECT_EQ(meta.at("channels"), 4);
    ASSERT_EQ(meta.at("maps").size(), 2u);
    EXPECT_EQ(meta.at("maps")[0].at("name"), "albedo"); // canonical order, whatever the form's
    EXPECT_EQ(meta.at("maps")[0].at("bits"), 8);
    EXPECT_EQ(meta.at("maps")[1].at("name"), "height");
    EXPECT_EQ(meta.at("maps")[1].at("first"), 3);
    EXPECT_EQ(meta.at("maps")[1].at("bits"), 16);
    EXPECT_EQ(meta.at("maps")[1].at("range").size(), 1u);
    for (const auto& m : meta.at("maps")) {
        EXPECT_GT(m.at("rme").get<double>(), 0.0);
        EXPECT_LT(m.at("rme").get<double>(), 1.0);
    }
    // Known: the same id, 200.
    auto again = c.Post("/v1/textons", form);
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 200);
    EXPECT_EQ(json::parse(again->body).at("id"), id);

    const std::string base = "/v1/textons/" + id;
    const core::Image plain = decoded(c.Get(base + "/tiles/0/1/2.exr?seed=7"));
    const core::Image alb = decoded(c.Get(base + "/tiles/0/1/2.exr?seed=7&map=albedo"));
    EXPECT_EQ(plain.channels, 3);
    EXPECT_EQ(plain.data, alb.data); // albedo is the default map
    EXPECT_EQ(decoded(c.Get(base + "/tiles/0/1/2.exr?seed=7&map=height")).channels, 1);

    // Normal tiles: two neighbours equal their region, bit for bit.
    const std::string n = "?seed=7&map=normal&strength=6";
    const core::Image left = decoded(c.Get(base + "/tiles/1/-1/3.exr" + n));
    const core::Image right = decoded(c.Get(base + "/tiles/1/0/3.exr" + n));
    const core::Image region = decoded(c.Get(base + "/region.exr?x=-256&y=768&w=512&h=256&z=1" +
                                             n.substr(0, 0) + "&seed=7&map=normal&strength=6"));
    ASSERT_EQ(region.channels, 3);
    int differ = 0;
    for (int ch = 0; ch < 3; ++ch)
        for (int y = 0; y < 256; ++y)
            for (int x = 0; x < 256; ++x) {
                differ += left.at(ch, x, y) != region.at(ch, x, y);
                differ += right.at(ch, x, y) != region.at(ch, 256 + x, y);
            }
    EXPECT_EQ(differ, 0);
    // Unit normals pointing up.
    for (std::size_t k = 0; k < left.plane_size(); k += 97) {
        const double x = 2.0 * left.plane(0)[k] - 1, y = 2.0 * left.plane(1)[k] - 1,
                     z = 2.0 * left.plane(2)[k] - 1;
        EXPECT_NEAR(x * x + y * y + z * z, 1.0, 1e-5);
        EXPECT_GT(z, 0.0);
    }
    // A tileable normal map resampled to a size that is not a multiple of the cell keeps unit
    // normals (resampling mixes neighbours; they are normalised again).
    const core::Image wrap = decoded(c.Get(base + "/tileable.exr?w=77&h=53&seed=7&map=normal"));
    ASSERT_EQ(wrap.width, 77);
    double off_unit = 0;
    for (std::size_t k = 0; k < wrap.plane_size(); ++k) {
        const double x = 2.0 * wrap.plane(0)[k] - 1, y = 2.0 * wrap.plane(1)[k] - 1,
                     z = 2.0 * wrap.plane(2)[k] - 1;
        off_unit = std::max(off_unit, std::fabs(std::sqrt(x * x + y * y + z * z) - 1.0));
    }
    EXPECT_LT(off_unit, 1e-5);
    // TileJSON carries the map.
    const json tj = json::parse(c.Get(base + "/tilejson.json?map=height")->body);
    EXPECT_NE(tj.at("tiles")[0].get<std::string>().find("&map=height"), std::string::npos);

    // Refusals, each with its reason.
    auto status = [&](const std::string& path) {
        auto r = c.Get(path);
        return r ? json::parse(r->body).at("error").at("code").get<std::string>() + " " +
                       std::to_string(r->status)
                 : std::string("no answer");
    };
    EXPECT_EQ(status(base + "/tiles/0/0/0.png?map=roughness"), "invalid_parameter 400");
    EXPECT_EQ(status(base + "/tiles/0/0/0.png?map=bump"), "invalid_parameter 400");
    EXPECT_EQ(status(base + "/tiles/0/0/0.png?strength=3"), "invalid_parameter 400");
    EXPECT_EQ(status(base + "/tiles/0/0/0.png?map=height&marginals=exemplar"),
              "invalid_parameter 400");
    // The true reason: a set has no exemplar marginals at all, however fresh;
    // "analysed before they were kept" was said of every set, tiles, elevation and TileJSON alike.
    for (const char* q : {"/tiles/0/0/0.png?map=height&marginals=exemplar",
                          "/map/24/0/0.png?map=height&encoding=terrarium&marginals=exemplar",
                          "/tilejson.json?map=height&encoding=terrarium&marginals=exemplar",
                          "/tiles/0/0/0.png?marginals=exemplar"}) {
        const std::string body = c.Get(base + q)->body;
        EXPECT_EQ(body.find("analysed before"), std::string::npos) << q << ": " << body;
        EXPECT_NE(body.find("material set"), std::string::npos) << q << ": " << body;
    }
}

// Elevation tiles (encoding=terrarium|mapbox): each pixel is the float height tile's value times
// height_scale in the encoding's bytes, so they decode to the float path within half a step,
// stitch as the float tiles do (two neighbours are the region's encoding, bit for bit), and a
// zoomed-out level encodes the box-averaged heights.
TEST(MaterialSet, ElevationTilesDecodeToTheFloatHeightsAndStitch) {
    TestServer server;
    auto c = server.client();
    const std::string base = upload_pebble_set(c);
    ASSERT_FALSE(base.empty());
    auto bytes = [](const core::Image& rgb, int x, int y) {
        return std::array<int, 3>{static_cast<int>(std::lround(rgb.at(0, x, y) * 255.0f)),
                                  static_cast<int>(std::lround(rgb.at(1, x, y) * 255.0f)),
                                  static_cast<int>(std::lround(rgb.at(2, x, y) * 255.0f))};
    };
    for (const auto e : {core::ElevationEncoding::terrarium, core::ElevationEncoding::mapbox}) {
        const std::string name = core::elevation_encoding_name(e);
        for (const int z : {24, 22}) { // level 0, and level 2 (box averages of 4 x 4 texels)
            const std::string at = "/map/" + std::to_string(z) + "/3/-2";
            const core::Image h = decoded(c.Get(base + at + ".exr?seed=7&map=height"));
            auto r =
                c.Get(base + at + ".png?seed=7&map=height&encoding=" + name + "&height_scale=250");
            const core::Image rgb = decoded(r);
            ASSERT_EQ(rgb.channels, 3);
            ASSERT_EQ(rgb.width, h.width);
            const core::Image expected = core::encode_elevation(h, e, 250.0);
            double worst = 0.0;
            int differ = 0;
            for (int y = 0; y < h.height; ++y)
                for (int x = 0; x < h.width; ++x) {
                    const auto b = bytes(rgb, x, y);
                    differ += b != bytes(expected, x, y);
                    worst = std::max(worst, std::fabs(core::decode_elevation(b[0], b[1], b[2], e) -
                                                      250.0 * h.at(0, x, y)));
                }
            EXPECT_EQ(differ, 0) << name << " z=" << z;
            EXPECT_LE(worst, core::elevation_step(e) / 2 + 1e-3) << name << " z=" << z;
        }
    }
    // Two neighbours and their region, on the float path, then encoded: the same bytes.
    const std::string q = "?seed=3&map=height&encoding=terrarium";
    const core::Image left = decoded(c.Get(base + "/tiles/1/-1/3.png" + q));
    const core::Image right = decoded(c.Get(base + "/tiles/1/0/3.png" + q));
    const core::Image region = core::encode_elevation(
        decoded(c.Get(base + "/region.exr?x=-256&y=768&w=512&h=256&z=1&seed=3&map=height")),
        core::ElevationEncoding::terrarium, api::kDefaultHeightScale);
    int seam = 0;
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x) {
            seam += bytes(left, x, y) != bytes(region, x, y);
            seam += bytes(right, x, y) != bytes(region, 256 + x, y);
        }
    EXPECT_EQ(seam, 0);
    // Without an extension: PNG whatever the Accept header asks for.
    auto plain = c.Get(base + "/tiles/0/0/0" + q, {{"Accept", "image/avif,image/webp"}});
    ASSERT_TRUE(plain);
    EXPECT_EQ(plain->status, 200);
    EXPECT_EQ(plain->get_header_value("Content-Type"), "image/png");
    // TileJSON: the encoding a raster-dem source needs, and templates that carry it.
    const json tj = json::parse(
        c.Get(base + "/tilejson.json?map=height&encoding=mapbox&height_scale=40")->body);
    EXPECT_EQ(tj.at("encoding"), "mapbox");
    EXPECT_EQ(tj.at("tileSize"), 256);
    EXPECT_EQ(tj.at("textond").at("height_scale"), 40.0);
    EXPECT_NE(
        tj.at("tiles")[0].get<std::string>().find("map=height&encoding=mapbox&height_scale=40"),
        std::string::npos);
    EXPECT_FALSE(json::parse(c.Get(base + "/tilejson.json?map=height")->body).contains("encoding"));
    // Refusals.
    auto refused = [&](const std::string& path, const std::string& words) {
        auto r = c.Get(path);
        ASSERT_TRUE(r);
        EXPECT_EQ(r->status, 400) << path;
        EXPECT_NE(r->body.find(words), std::string::npos) << path << ": " << r->body;
    };
    refused(base + "/tiles/0/0/0.png?encoding=terrarium", "map=height only");
    refused(base + "/tiles/0/0/0.png?map=albedo&encoding=mapbox", "map=height only");
    refused(base + "/tiles/0/0/0.webp?map=height&encoding=mapbox", "ask for .png");
    refused(base + "/tiles/0/0/0.png?map=height&encoding=srtm", "terrarium or mapbox");
    refused(base + "/tiles/0/0/0.png?map=height&height_scale=3", "elevation tiles only");
    refused(base + "/tiles/0/0/0.png?map=height&encoding=mapbox&height_scale=0", "height_scale");
    refused(base + "/region.png?map=height&encoding=mapbox", "encoding");
}

// map=lit: the albedo times 0.35 + 0.65 max(0, n . l), with n from the normal tiles of the same
// window and l from light=AZ,EL; lit tiles stitch into their region bit for bit; the light moves
// the shading; the refusals.
TEST(MaterialSet, LitTilesShadeTheAlbedoThroughTheNormalsAndStitch) {
    TestServer server;
    auto c = server.client();
    const std::string base = upload_pebble_set(c);
    ASSERT_FALSE(base.empty());
    const std::string q = "?seed=3&strength=5";
    const core::Image albedo = decoded(c.Get(base + "/tiles/0/2/-1.exr?seed=3"));
    const core::Image normals = decoded(c.Get(base + "/tiles/0/2/-1.exr" + q + "&map=normal"));
    for (const auto& [light, az, el] : std::vector<std::tuple<std::string, double, double>>{
             {"", 135.0, 45.0}, {"&light=300,20", 300.0, 20.0}, {"&light=0,90", 0.0, 90.0}}) {
        const core::Image lit = decoded(c.Get(base + "/tiles/0/2/-1.exr" + q + "&map=lit" + light));
        ASSERT_EQ(lit.channels, 3);
        const double a = az * M_PI / 180, e = el * M_PI / 180;
        const double l[3] = {std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)};
        double worst = 0, darkest = 1;
        for (std::size_t k = 0; k < lit.plane_size(); ++k) {
            double dot = 0;
            for (int ch = 0; ch < 3; ++ch) dot += (2.0 * normals.plane(ch)[k] - 1.0) * l[ch];
            const double shade = 0.35 + 0.65 * std::max(0.0, dot);
            darkest = std::min(darkest, shade);
            for (int ch = 0; ch < 3; ++ch)
                worst = std::max(worst, std::fabs(lit.plane(ch)[k] - albedo.plane(ch)[k] * shade));
        }
        EXPECT_LE(worst, 1e-6) << light;
        EXPECT_LT(darkest, 0.6) << light << ": the relief must shade some pixels";
    }
    // Lit tiles are windows onto one function: two neighbours equal their region.
    const std::string lq = "?seed=3&map=lit&light=200,35";
    const core::Image left = decoded(c.Get(base + "/tiles/2/-1/0.exr" + lq));
    const core::Image right = decoded(c.Get(base + "/tiles/2/0/0.exr" + lq));
    const core::Image region =
        decoded(c.Get(base + "/region.exr?x=-256&y=0&w=512&h=256&z=2&seed=3&map=lit&light=200,35"));
    int differ = 0;
    for (int ch = 0; ch < 3; ++ch)
        for (int y = 0; y < 256; ++y)
            for (int x = 0; x < 256; ++x) {
                differ += left.at(ch, x, y) != region.at(ch, x, y);
                differ += right.at(ch, x, y) != region.at(ch, 256 + x, y);
            }
    EXPECT_EQ(differ, 0);
    const json tj = json::parse(c.Get(base + "/tilejson.json?map=lit&light=200,35")->body);
    EXPECT_NE(tj.at("tiles")[0].get<std::string>().find("&map=lit&strength=8&light=200,35"),
              std::string::npos)
        << tj.dump();
    auto code = [&](const std::string& path) {
        auto r = c.Get(path);
        return r ? json::parse(r->body).at("error").at("code").get<std::string>() + " " +
                       std::to_string(r->status)
                 : std::string("no answer");
    };
    EXPECT_EQ(code(base + "/tiles/0/0/0.png?light=10,10"), "invalid_parameter 400");
    EXPECT_EQ(code(base + "/tiles/0/0/0.png?map=normal&light=10,10"), "invalid_parameter 400");
    EXPECT_EQ(code(base + "/tiles/0/0/0.png?map=lit&light=10"), "invalid_parameter 400");
    EXPECT_EQ(code(base + "/tiles/0/0/0.png?map=lit&light=10,0"), "invalid_parameter 400");
    EXPECT_EQ(code(base + "/tiles/0/0/0.png?map=lit&light=400,10"), "invalid_parameter 400");
    auto plain = c.Post("/v1/textons?size=16&iterations=5",
                        read_file(exemplar_path("etr_pebbles04.png")), "image/png");
    ASSERT_TRUE(plain);
    auto t = c.Get("/v1/textons/" + json::parse(plain->body).at("id").get<std::string>() +
                   "/tiles/0/0/0.png?map=lit");
    ASSERT_TRUE(t);
    EXPECT_EQ(t->status, 400);
    EXPECT_NE(t->body.find("map=lit needs a material set"), std::string::npos) << t->body;
}

// A set on surfaces: colours of a map (albedo by default, 3 channels; the height 1), and mesh.png
// lit through the height's relief by default (CPU), flat with map=albedo, the same coverage;
// light= moves the shading; a vanishing strength gives the flat picture (up to the rasteriser:
// the flat one may be OpenGL's); the refusals.
TEST(MaterialSet, MeshPreviewShowsTheReliefAndSurfaceColoursAMap) {
    TestServer server;
    auto c = server.client();
    const std::string base = upload_pebble_set(c);
    ASSERT_FALSE(base.empty());
    const std::string points = R"({"points":[[0,0,0],[10,5,2]],"normals":[[0,0,1],[0,1,0]]})";
    auto colours = [&](const std::string& q) {
        auto r = c.Post(base + "/surface?seed=1" + q, points, "application/json");
        EXPECT_TRUE(r && r->status == 200) << (r ? r->body : "no answer");
        return json::parse(r->body);
    };
    EXPECT_EQ(colours("").at("channels"), 3);
    EXPECT_EQ(colours("").at("colors"), colours("&map=albedo").at("colors"));
    EXPECT_EQ(colours("&map=height").at("channels"), 1);

    const std::string quad = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n";
    auto mesh = [&](const std::string& q, std::string* backend = nullptr) {
        auto r = c.Post(base + "/mesh.png?width=96&height=96&seed=2" + q, quad, "model/obj");
        EXPECT_TRUE(r && r->status == 200) << (r ? r->body : "no answer");
        if (backend) *backend = r->get_header_value("X-Textond-Backend");
        return io::decode_image_memory(r->body).value();
    };
    std::string backend;
    const core::Image lit = mesh("", &backend);
    EXPECT_EQ(backend, "cpu");
    const core::Image flat = mesh("&map=albedo");
    const core::Image faint = mesh("&strength=0.000001");
    const core::Image moved = mesh("&light=200,30");
    // The decoder drops alpha; the background is black and the mesh never is (albedo x >= 0.35).
    auto on = [](const core::Image& im, int x, int y) {
        return im.at(0, x, y) + im.at(1, x, y) + im.at(2, x, y) > 0.0f;
    };
    // The flat one may be drawn by OpenGL (the relief only on the CPU): edges may differ.
    int covered = 0, edge = 0, relief = 0, faint_off = 0, light_moves = 0;
    for (int y = 0; y < 96; ++y)
        for (int x = 0; x < 96; ++x) {
            edge += on(lit, x, y) != on(flat, x, y);
            if (!on(lit, x, y) || !on(flat, x, y) || !on(faint, x, y)) continue;
            ++covered;
            double d = 0, f = 0, m = 0;
            for (int ch = 0; ch < 3; ++ch) {
                d = std::max(d, double(std::fabs(lit.at(ch, x, y) - flat.at(ch, x, y))));
                f = std::max(f, double(std::fabs(faint.at(ch, x, y) - flat.at(ch, x, y))));
                m = std::max(m, double(std::fabs(moved.at(ch, x, y) - lit.at(ch, x, y))));
            }
            relief += d > 2.5 / 255;
            faint_off += f > 1.5 / 255; // one 8-bit step of rounding
            light_moves += m > 2.5 / 255;
        }
    ASSERT_GT(covered, 1000);
    EXPECT_LT(edge, covered / 50);
    EXPECT_GT(relief, covered / 2) << "the relief must change most pixels' shading";
    EXPECT_EQ(faint_off, 0) << "strength -> 0 must give the flat mesh";
    EXPECT_GT(light_moves, covered / 2);

    auto code = [&](const std::string& path, const std::string& body, const char* type) {
        auto r = c.Post(path, body, type);
        return r ? json::parse(r->body).at("error").at("code").get<std::string>() + " " +
                       std::to_string(r->status)
                 : std::string("no answer");
    };
    EXPECT_EQ(code(base + "/mesh.png?map=normal", quad, "model/obj"), "invalid_parameter 400");
    EXPECT_EQ(code(base + "/mesh.png?light=10", quad, "model/obj"), "invalid_parameter 400");
    EXPECT_EQ(code(base + "/mesh.png?map=albedo&strength=2", quad, "model/obj"),
              "invalid_parameter 400");
    EXPECT_EQ(code(base + "/surface?map=lit", points, "application/json"), "invalid_parameter 400");
    EXPECT_EQ(code(base + "/surface?map=roughness", points, "application/json"),
              "invalid_parameter 400");
}

// `textond export` of a set's views (its texton.exr from the server): each archived tile is the
// server's tile of that view, byte for byte (both store PNGs, --png-compression 0).
TEST(MaterialSet, ExportedViewsAreTheServersTiles) {
    TestServer server;
    auto c = server.client();
    const std::string base = upload_pebble_set(c);
    ASSERT_FALSE(base.empty());
    const std::string texton = temp_path("pebble-set.exr");
    {
        auto r = c.Get(base + "/texton.exr");
        ASSERT_TRUE(r && r->status == 200);
        ASSERT_TRUE(io::write_file_atomic(texton, r->body).ok());
    }
    for (const std::string& view : {std::string("albedo"), std::string("height"),
                                    std::string("normal"), std::string("lit")}) {
        const std::string out = temp_path("pebble-" + view + ".mbtiles");
        std::remove(out.c_str());
        const RunResult r = run("export " + texton + " --zooms 24 --bbox 256,0,512,256 --map " +
                                view + " --seed 5 --png-compression 0 --quiet -o " + out);
        ASSERT_EQ(r.code, 0) << view << ": " << r.err;
        auto archive = io::Mbtiles::open(out);
        ASSERT_TRUE(archive.ok()) << archive.error().message;
        auto archived = archive.value()->get(24, 1, 0);
        ASSERT_TRUE(archived.ok()) << view << ": " << archived.error().message;
        auto tile = c.Get(base + "/map/24/1/0.png?seed=5&map=" + view);
        ASSERT_TRUE(tile && tile->status == 200) << view;
        EXPECT_TRUE(archived.value() == tile->body) << view << ": not the server's tile";
    }
}

// A one-channel map of the photo's luminance L through f, as a 16-bit PNG, and its mean.
template <typename F> std::pair<std::string, double> luminance_map(const core::Image& u, F f) {
    core::Image m(u.width, u.height, 1);
    double sum = 0;
    for (int y = 0; y < u.height; ++y)
        for (int x = 0; x < u.width; ++x) {
            const float l = (u.at(0, x, y) + u.at(1, x, y) + u.at(2, x, y)) / 3.0f;
            m.at(0, x, y) = f(l);
            sum += m.at(0, x, y);
        }
    return {io::encode_image_memory(m, io::Encoding::png16).value(),
            sum / static_cast<double>(m.plane_size())};
}

// Every documented map (albedo, height, roughness, ao, metallic) in any part order: 201, and
// each map's tiles have that map's mean. The texton file stores channels sorted by name, so a
// set whose maps were not in alphabetical order failed its own checksum on reading (500).
TEST(MaterialSet, EveryMapInAnyPartOrderIsStoredAndServedAsItself) {
    TestServer server;
    auto c = server.client();
    const core::Image u = load_exemplar("etr_pebbles04.png");
    const std::string albedo = read_file(exemplar_path("etr_pebbles04.png"));
    const auto height = luminance_map(u, [](float l) { return l; });
    const auto ao = luminance_map(u, [](float l) { return 0.8f + 0.05f * l; });
    const auto metallic = luminance_map(u, [](float l) { return 0.05f + 0.1f * l; });
    const auto roughness = luminance_map(u, [](float l) { return 0.28f + 0.05f * l; });
    const std::map<std::string, std::pair<std::string, double>> maps = {
        {"height", height}, {"ao", ao}, {"metallic", metallic}, {"roughness", roughness}};
    const std::vector<std::vector<std::string>> orders = {
        {"metallic", "ao", "height", "albedo"},
        {"ao", "albedo"},
        {"albedo", "ao", "metallic"},
        {"roughness", "metallic", "albedo", "height", "ao"}};
    for (const auto& order : orders) {
        httplib::MultipartFormDataItems form = {{"size", "16", "", ""},
                                                {"iterations", "10", "", ""}};
        for (const std::string& name : order)
            form.push_back({name, name == "albedo" ? albedo : maps.at(name).first, name + ".png",
                            "image/png"});
        auto up = c.Post("/v1/textons", form);
        ASSERT_TRUE(up);
        ASSERT_EQ(up->status, 201) << ::testing::PrintToString(order) << ": " << up->body;
        const json meta = json::parse(up->body);
        EXPECT_EQ(meta.at("maps").size(), order.size());
        const std::string base = "/v1/textons/" + meta.at("id").get<std::string>();
        for (const std::string& name : order) {
            if (name == "albedo") continue;
            const core::Image t = decoded(c.Get(base + "/tiles/0/0/0.exr?seed=3&map=" + name));
            ASSERT_EQ(t.channels, 1) << name;
            double sum = 0;
            for (float v : t.data) sum += v;
            // The maps' means are 0.15 apart or more; a tile's mean is within a few 0.01.
            EXPECT_NEAR(sum / static_cast<double>(t.data.size()), maps.at(name).second, 0.06)
                << name << " in " << ::testing::PrintToString(order);
        }
    }
}

TEST(MaterialSet, MismatchedSizesAndNormalUploadsAreRefusedClearly) {
    TestServer server;
    auto c = server.client();
    const std::string albedo = read_file(exemplar_path("etr_pebbles04.png"));
    const core::Image u = load_exemplar("etr_pebbles04.png");
    httplib::MultipartFormDataItems form = {
        {"albedo", albedo, "a.png", "image/png"},
        {"height", height_png16(u, u.width - 8), "h.png", "image/png"},
        {"size", "16", "", ""}};
    auto r = c.Post("/v1/textons", form);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 400);
    EXPECT_EQ(json::parse(r->body).at("error").at("code"), "map_size_mismatch");
    EXPECT_NE(r->body.find("one size"), std::string::npos) << r->body;

    form = {{"albedo", albedo, "a.png", "image/png"}, {"normal", albedo, "n.png", "image/png"}};
    r = c.Post("/v1/textons", form);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 400);
    EXPECT_NE(r->body.find("upload 'height'"), std::string::npos) << r->body;

    form = {{"albedo", albedo, "a.png", "image/png"}, {"exemplar", albedo, "e.png", "image/png"}};
    r = c.Post("/v1/textons", form);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 400);

    // A set holds at most an RGB exemplar's pixels in all: with --max-pixels 65536 (each 256 x 256
    // map alone fits), albedo fits (3 x 65536) and albedo plus height does not: 413.
    {
        auto small = TestServer::default_config();
        small.max_pixels = 256 * 256;
        TestServer limited(small);
        auto lc = limited.client();
        const core::Image sand = load_exemplar("etr_sand01.png");
        ASSERT_EQ(sand.width * sand.height, 256 * 256);
        httplib::MultipartFormDataItems one = {
            {"albedo", read_file(exemplar_path("etr_sand01.png")), "a.png", "image/png"},
            {"size", "16", "", ""}};
        auto ok = lc.Post("/v1/textons", one);
        ASSERT_TRUE(ok);
        EXPECT_EQ(ok->status, 201) << ok->body;
        one.insert(one.begin(), {"height", height_png16(sand, sand.width), "h.png", "image/png"});
        auto big = lc.Post("/v1/textons", one);
        ASSERT_TRUE(big);
        EXPECT_EQ(big->status, 413) << big->body;
        EXPECT_NE(big->body.find("channel-pixels"), std::string::npos) << big->body;
    }
    // A plain texton has no maps.
    auto plain = c.Post("/v1/textons?size=16&iterations=5", albedo, "image/png");
    ASSERT_TRUE(plain);
    const std::string id = json::parse(plain->body).at("id");
    auto t = c.Get("/v1/textons/" + id + "/tiles/0/0/0.png?map=height");
    ASSERT_TRUE(t);
    EXPECT_EQ(t->status, 400);
    EXPECT_NE(t->body.find("material set"), std::string::npos) << t->body;
}

} // namespace
} // namespace textond::test
