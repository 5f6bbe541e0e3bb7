// A table of bad requests (OSRM style): each gets its status and error code in the one JSON
// error body, nothing is stored, and the server is healthy afterwards.
#include "server/io/image_io.h"
#include "tests/server/server_fixture.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>

namespace textond::test {
namespace {

using nlohmann::json;

std::uint32_t crc32(const std::string& bytes) {
    std::uint32_t c = 0xffffffffu;
    for (unsigned char b : bytes) {
        c ^= b;
        for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return ~c;
}

std::string be32(std::uint32_t v) {
    return {static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8),
            static_cast<char>(v)};
}

// A well-formed PNG header that declares width x height pixels (a decompression bomb's shape).
std::string png_declaring(std::uint32_t width, std::uint32_t height) {
    const std::string ihdr = "IHDR" + be32(width) + be32(height) + std::string("\x08\x02\0\0\0", 5);
    return std::string("\x89PNG\r\n\x1a\n", 8) + be32(13) + ihdr + be32(crc32(ihdr)) + be32(0) +
           "IDAT" + be32(crc32("IDAT")) + be32(0) + "IEND" + be32(crc32("IEND"));
}

std::string nan_exr() {
    core::Image im(64, 64, 3, 0.5f);
    im.at(1, 10, 10) = std::numeric_limits<float>::quiet_NaN();
    return io::encode_image_memory(im, io::Encoding::exr).value();
}

struct Bad {
    const char* what;
    const char* method; // GET, POST, DELETE
    std::string path;
    std::string body;
    int status;
    const char* code;
};

void expect_error(const httplib::Result& res, const Bad& b) {
    ASSERT_TRUE(res) << b.what << ": no response";
    EXPECT_EQ(res->status, b.status) << b.what << ": " << res->body;
    EXPECT_EQ(res->get_header_value("Content-Type"), "application/json") << b.what;
    json j;
    ASSERT_NO_THROW(j = json::parse(res->body)) << b.what << ": " << res->body;
    EXPECT_EQ(j["error"]["code"], b.code) << b.what << ": " << res->body;
    EXPECT_FALSE(j["error"]["message"].get<std::string>().empty()) << b.what;
    EXPECT_EQ(j["request_id"], res->get_header_value("X-Request-Id")) << b.what;
}

TEST(BadRequests, EachGetsItsStatusAndCodeAndNothingBreaks) {
    http::ServeConfig config = TestServer::default_config();
    config.max_upload_bytes = 1 << 20;
    config.formats = {"png", "openexr", "tiff"};
    TestServer server(config);
    auto c = server.client();
    c.set_url_encode(false); // send the paths exactly as written
    const std::string id = upload(c, "etr_sand01.png", "?size=16&iterations=5");
    ASSERT_FALSE(id.empty());
    const std::string t = "/v1/textons/" + id;
    const std::string png = read_file(exemplar_path("etr_sand01.png"));
    const std::string unknown(64, 'a');
    std::string corrupt = png;
    for (std::size_t i = 100; i < corrupt.size(); i += 7)
        corrupt[i] = static_cast<char>(~corrupt[i]);
    std::string jpeg;
    {
        auto j = io::encode_image_memory(load_exemplar("etr_sand01.png"), io::Encoding::png8);
        jpeg = std::string("\xff\xd8\xff\xe0", 4) + j.value().substr(4); // JPEG magic, not allowed
    }

    const std::vector<Bad> table = {
        // Uploads
        {"corrupt PNG", "POST", "/v1/textons", corrupt, 422, "invalid_image"},
        {"truncated PNG", "POST", "/v1/textons", png.substr(0, png.size() / 2), 422,
         "invalid_image"},
        {"zero bytes", "POST", "/v1/textons", "", 400, "empty_body"},
        {"text as image", "POST", "/v1/textons", "hello, I am not a picture", 415,
         "unsupported_media_type"},
        {"declared 100000x100000 PNG", "POST", "/v1/textons", png_declaring(100000, 100000), 413,
         "image_too_large"},
        {"body over the upload limit", "POST", "/v1/textons", std::string(2 << 20, 'x'), 413,
         "payload_too_large"},
        {"GIF (not a format we read)", "POST", "/v1/textons", "GIF89a" + std::string(200, '\0'),
         415, "unsupported_media_type"},
        {"JPEG (not in this server's allow-list)", "POST", "/v1/textons", jpeg, 415,
         "unsupported_media_type"},
        {"NaN in an EXR", "POST", "/v1/textons", nan_exr(), 422, "invalid_image"},
        {"exemplar smaller than the texton", "POST", "/v1/textons?size=256", png, 422,
         "exemplar_too_small"},
        {"size 0", "POST", "/v1/textons?size=0", png, 400, "invalid_parameter"},
        {"order 7", "POST", "/v1/textons?order=7", png, 400, "invalid_parameter"},
        {"order 2 (no such B-spline order)", "POST", "/v1/textons?order=2", png, 400,
         "invalid_parameter"},
        {"iterations not a number", "POST", "/v1/textons?iterations=ten", png, 400,
         "invalid_parameter"},
        {"periodic not a boolean", "POST", "/v1/textons?periodic=maybe", png, 400,
         "invalid_parameter"},
        {"unknown analysis parameter", "POST", "/v1/textons?sise=32", png, 400,
         "unknown_parameter"},
        {"parameter given twice", "POST", "/v1/textons?size=32&size=16", png, 400,
         "invalid_parameter"},
        // Ids
        {"unknown id", "GET", "/v1/textons/" + unknown, "", 404, "not_found"},
        {"unknown id, tile", "GET", "/v1/textons/" + unknown + "/tiles/0/0/0.png", "", 404,
         "not_found"},
        {"unknown id, delete", "DELETE", "/v1/textons/" + unknown, "", 404, "not_found"},
        {"../ in the id", "GET", "/v1/textons/../../etc/passwd", "", 400, "invalid_id"},
        // Refused before routing: no path here is written with a percent-encoding.
        {"encoded ../ in the id", "GET", "/v1/textons/..%2F..%2Fetc%2Fpasswd/tiles/0/0/0.png", "",
         400, "non_canonical_url"},
        {"encoded / in a path", "GET", "/v1%2Ftextons", "", 400, "non_canonical_url"},
        {"uppercase id", "GET", "/v1/textons/" + std::string(64, 'A'), "", 400, "invalid_id"},
        {"overlong id", "GET", "/v1/textons/" + std::string(65, 'a'), "", 400, "invalid_id"},
        {"very long id", "GET", "/v1/textons/" + std::string(4000, 'a') + "/texton.png", "", 400,
         "invalid_id"},
        {"URI over the limit", "GET", "/v1/textons/" + std::string(20000, 'a'), "", 414,
         "uri_too_long"},
        {"delete with a bad id", "DELETE", "/v1/textons/abc", "", 400, "invalid_id"},
        // Tiles
        {"tile x past int64", "GET", t + "/tiles/0/9223372036854775808/0.png", "", 400,
         "coordinate_out_of_range"},
        {"tile y past int64 (negative)", "GET", t + "/tiles/0/0/-9223372036854775809.png", "", 400,
         "coordinate_out_of_range"},
        {"tile x whose pixels leave the plane", "GET", t + "/tiles/0/1152921504606846976/0.png", "",
         400, "coordinate_out_of_range"},
        {"tile on the plane at level 0 but not at level 20", "GET",
         t + "/tiles/20/17592186044416/0.png", "", 400, "coordinate_out_of_range"},
        {"tile x not a number", "GET", t + "/tiles/0/1e3/0.png", "", 400,
         "coordinate_out_of_range"},
        {"level too high", "GET", t + "/tiles/25/0/0.png", "", 400, "level_out_of_range"},
        {"level too low", "GET", t + "/tiles/-5/0/0.png", "", 400, "level_out_of_range"},
        {"map zoom too high", "GET", t + "/map/29/0/0.png", "", 400, "level_out_of_range"},
        {"mni -1", "GET", t + "/tiles/0/0/0.png?mni=-1", "", 400, "invalid_parameter"},
        {"mni nan", "GET", t + "/tiles/0/0/0.png?mni=nan", "", 400, "invalid_parameter"},
        {"seed -1", "GET", t + "/tiles/0/0/0.png?seed=-1", "", 400, "invalid_parameter"},
        {"tile size 300", "GET", t + "/tiles/0/0/0.png?size=300", "", 400, "invalid_parameter"},
        {"tile format jpg", "GET", t + "/tiles/0/0/0.jpg", "", 400, "invalid_format"},
        {"unknown tile parameter", "GET", t + "/tiles/0/0/0.png?zoom=3", "", 400,
         "unknown_parameter"},
        // Regions, tileable, lists
        {"region too large", "GET", t + "/region.png?w=4000&h=4000", "", 400, "region_too_large"},
        {"region w 0", "GET", t + "/region.png?w=0", "", 400, "invalid_parameter"},
        {"region x past int64", "GET", t + "/region.png?x=99999999999999999999", "", 400,
         "coordinate_out_of_range"},
        {"region off the plane", "GET", t + "/region.png?x=4611686018427387900", "", 400,
         "coordinate_out_of_range"},
        {"region level out of range", "GET", t + "/region.png?z=99", "", 400, "level_out_of_range"},
        {"tileable too large", "GET", t + "/tileable.png?w=100000", "", 400, "invalid_parameter"},
        {"tileable too small", "GET", t + "/tileable.png?w=2", "", 400, "invalid_parameter"},
        {"list limit 0", "GET", "/v1/textons?limit=0", "", 400, "invalid_parameter"},
        {"list cursor not an id", "GET", "/v1/textons?after=zzz", "", 400, "invalid_id"},
        {"texton view format", "GET", t + "/texton.jpg", "", 400, "invalid_format"},
        {"no such endpoint", "GET", "/v2/textons", "", 404, "not_found"},
        {"no such endpoint under a texton", "GET", t + "/nothing", "", 404, "not_found"},
    };
    for (const Bad& b : table) {
        SCOPED_TRACE(b.what);
        const std::string m = b.method;
        httplib::Result res = m == "POST"     ? c.Post(b.path.c_str(), b.body, "image/png")
                              : m == "DELETE" ? c.Delete(b.path.c_str())
                                              : c.Get(b.path.c_str());
        expect_error(res, b);
    }

    httplib::MultipartFormDataItems no_file = {{"size", "32", "", ""}};
    expect_error(c.Post("/v1/textons", no_file),
                 {"multipart without exemplar", "POST", "", "", 400, "missing_exemplar"});

    // Nothing was stored by the failures, and everything still works.
    EXPECT_EQ(json::parse(c.Get("/v1/textons")->body).at("total"), 1);
    EXPECT_EQ(c.Get("/healthz")->status, 200);
    EXPECT_EQ(c.Get("/readyz")->status, 200);
    EXPECT_EQ(c.Get((t + "/tiles/0/0/0.png").c_str())->status, 200);
    // Tiles never run out: the last tile on the plane at level 0 is a 200.
    const long long last = (1LL << 62) / 256 - 1;
    EXPECT_EQ(
        c.Get((t + "/tiles/0/" + std::to_string(last) + "/" + std::to_string(-last - 1) + ".png")
                  .c_str())
            ->status,
        200);
}

// Messages say what was asked of what: a surface body that is no object, map=lit on a texton of
// one exemplar, and ids by the kind of route.
TEST(BadRequests, MessagesNameWhatWasAsked) {
    TestServer server;
    auto c = server.client();
    const std::string id = upload(c, "etr_sand01.png", "?size=16&iterations=5");
    auto message = [](const httplib::Result& r) {
        return r ? json::parse(r->body)["error"]["message"].get<std::string>() : "no answer";
    };
    const std::string surface = "/v1/textons/" + id + "/surface";
    for (const char* body : {"[1]", "1"})
        EXPECT_NE(message(c.Post(surface.c_str(), body, "application/json"))
                      .find("the body must be a JSON object"),
                  std::string::npos)
            << body;
    const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    EXPECT_NE(message(c.Post(("/v1/textons/" + id + "/mesh.png?map=lit").c_str(), obj, "model/obj"))
                  .find("map=lit needs a material set"),
              std::string::npos);
    EXPECT_NE(message(c.Get("/v1/mixes/zz")).find("mix ids are"), std::string::npos);
    EXPECT_NE(message(c.Get("/v1/splats/zz")).find("splat ids are"), std::string::npos);
    EXPECT_NE(message(c.Get("/v1/mixes/zz/tiles/0/0/0.png")).find("texton, mix and splat ids"),
              std::string::npos);
    // Routes no query changes take none: one answer, one URL, one cache entry.
    for (const char* route :
         {"/texton.png", "/texton.exr", "/texton.texton", "/exemplar.png", "/status"}) {
        const std::string url = "/v1/textons/" + id + route;
        EXPECT_EQ(c.Get(url.c_str())->status, 200) << route;
        auto r = c.Get((url + "?x=1").c_str());
        ASSERT_TRUE(r);
        EXPECT_EQ(r->status, 400) << route;
        EXPECT_EQ(json::parse(r->body)["error"]["code"], "unknown_parameter") << route;
        // A signed link to it still opens (the signer signs any path).
        EXPECT_EQ(c.Get((url + "?exp=4102444800&sig=00").c_str())->status, 200) << route;
    }
}

} // namespace
} // namespace textond::test
