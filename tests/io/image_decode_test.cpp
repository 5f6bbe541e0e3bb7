#include "server/io/image_io.h"
#include "tests/support/test_support.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <thread>
#include <vector>

using namespace textond;
namespace fs = std::filesystem;

namespace {
fs::path temp_dir() {
    static const fs::path d = [] {
        fs::path p = fs::temp_directory_path() / ("textond-io-test-" + std::to_string(::getpid()));
        fs::create_directories(p);
        return p;
    }();
    return d;
}

// A smooth test pattern with `nch` interleaved channels, values in [0, 1].
std::vector<float> pattern(int w, int h, int nch) {
    std::vector<float> v(static_cast<std::size_t>(w) * h * nch);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < nch; ++c)
                v[(static_cast<std::size_t>(y) * w + x) * nch + c] =
                    0.5f +
                    0.4f * std::sin(0.11f * static_cast<float>(x) + 0.07f * static_cast<float>(y) +
                                    1.3f * static_cast<float>(c));
    return v;
}

std::string write_with_oiio(const std::string& name, int w, int h, int nch, OIIO::TypeDesc type,
                            const std::vector<float>& pixels, bool alpha_last = false) {
    const std::string path = (temp_dir() / name).string();
    OIIO::ImageSpec spec(w, h, nch, type);
    if (alpha_last) {
        spec.alpha_channel = nch - 1;
        spec.attribute("oiio:UnassociatedAlpha", 1); // store colour unpremultiplied
    }
    auto out = OIIO::ImageOutput::create(path);
    EXPECT_TRUE(out) << OIIO::geterror();
    EXPECT_TRUE(out->open(path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()) &&
                out->close())
        << out->geterror();
    return path;
}

std::string write_bytes(const std::string& name, const std::string& bytes) {
    const std::string path = (temp_dir() / name).string();
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
}

struct FormatCase {
    const char* name;
    OIIO::TypeDesc type;
    int file_channels;
    bool alpha;
    int expect_channels;
    double tolerance;
};
} // namespace

class DecodeFormats : public ::testing::TestWithParam<FormatCase> {};

TEST_P(DecodeFormats, RoundTripsWithTheDocumentedChannelsAndRange) {
    const FormatCase& fc = GetParam();
    const int w = 37, h = 23;
    const auto src = pattern(w, h, fc.file_channels);
    const std::string path =
        write_with_oiio(fc.name, w, h, fc.file_channels, fc.type, src, fc.alpha);
    auto r = io::decode_image_file(path);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const core::Image& img = r.value();
    // Uploads decode from memory, through the service's own I/O proxy: the same pixels.
    const std::string bytes = io::read_file(path).value();
    auto m = io::decode_image_memory(bytes);
    ASSERT_TRUE(m.ok()) << m.error().message;
    EXPECT_EQ(test::max_abs_diff(m.value(), img), 0.0);
    ASSERT_EQ(img.width, w);
    ASSERT_EQ(img.height, h);
    ASSERT_EQ(img.channels, fc.expect_channels);
    double worst = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < img.channels; ++c) {
                const float want =
                    src[(static_cast<std::size_t>(y) * w + x) * fc.file_channels + c];
                worst = std::max(worst, std::abs(double(img.at(c, x, y)) - want));
            }
    EXPECT_LT(worst, fc.tolerance);
}

INSTANTIATE_TEST_SUITE_P(
    Formats, DecodeFormats,
    ::testing::Values(FormatCase{"rgb8.png", OIIO::TypeDesc::UINT8, 3, false, 3, 0.6 / 255},
                      FormatCase{"rgb16.png", OIIO::TypeDesc::UINT16, 3, false, 3, 0.6 / 65535},
                      FormatCase{"grey8.png", OIIO::TypeDesc::UINT8, 1, false, 1, 0.6 / 255},
                      FormatCase{"greyalpha8.png", OIIO::TypeDesc::UINT8, 2, true, 1, 0.6 / 255},
                      FormatCase{"rgba16.png", OIIO::TypeDesc::UINT16, 4, true, 3, 0.6 / 65535},
                      FormatCase{"rgb.jpg", OIIO::TypeDesc::UINT8, 3, false, 3, 0.08},
                      FormatCase{"rgb8.tif", OIIO::TypeDesc::UINT8, 3, false, 3, 0.6 / 255},
                      FormatCase{"rgbf.tif", OIIO::TypeDesc::FLOAT, 3, false, 3, 1e-7},
                      FormatCase{"half.exr", OIIO::TypeDesc::HALF, 3, false, 3, 1e-3},
                      FormatCase{"float.exr", OIIO::TypeDesc::FLOAT, 3, false, 3, 1e-7},
                      FormatCase{"rgba.exr", OIIO::TypeDesc::HALF, 4, true, 3, 1e-3},
                      FormatCase{"rgb.bmp", OIIO::TypeDesc::UINT8, 3, false, 3, 0.6 / 255}),
    [](const auto& test_info) {
        std::string n = test_info.param.name;
        for (auto& ch : n)
            if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
        return n;
    });

TEST(Decode, PalettePngBecomesRgbAndGreyPngStaysOneChannel) {
    auto cork = io::decode_image_file(test::exemplar_path("mypaint_HR_Cork.png"));
    ASSERT_TRUE(cork.ok());
    EXPECT_EQ(cork.value().channels, 3);
    auto gravel = io::decode_image_file(test::exemplar_path("skimage_gravel.png"));
    ASSERT_TRUE(gravel.ok());
    EXPECT_EQ(gravel.value().channels, 1);
    for (float v : gravel.value().data) ASSERT_TRUE(v >= 0.0f && v <= 1.0f);
}

TEST(Decode, FromMemoryEqualsFromFile) {
    const std::string path = test::exemplar_path("etr_sand01.png");
    auto a = io::decode_image_file(path);
    auto b = io::decode_image_memory(io::read_file(path).value());
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(a.value().data, b.value().data);
}

TEST(Decode, RefusesOverBudgetFromTheHeaderBeforeDecoding) {
    io::DecodeLimits limits;
    limits.max_pixels = 256 * 256 - 1;
    auto r = io::decode_image_file(test::exemplar_path("etr_sand01.png"), limits);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::too_large);
    EXPECT_NE(r.error().message.find("65536"), std::string::npos);
}

TEST(Decode, RefusesNanAndInfinity) {
    auto px = pattern(8, 8, 3);
    px[17] = std::nanf("");
    auto r = io::decode_image_file(write_with_oiio("nan.exr", 8, 8, 3, OIIO::TypeDesc::FLOAT, px));
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::unprocessable);
    EXPECT_NE(r.error().message.find("NaN"), std::string::npos);
    px[17] = INFINITY;
    EXPECT_FALSE(
        io::decode_image_file(write_with_oiio("inf.exr", 8, 8, 3, OIIO::TypeDesc::FLOAT, px)).ok());
}

TEST(Decode, BadFilesGiveClearErrorsNotCrashes) {
    const std::string png = io::read_file(test::exemplar_path("etr_sand01.png")).value();
    struct Bad {
        std::string name, bytes;
    };
    std::string corrupt = png;
    for (std::size_t k = 200; k < corrupt.size(); k += 97)
        corrupt[k] = static_cast<char>(corrupt[k] ^ 0x5a);
    const Bad cases[] = {
        {"empty.png", ""},
        {"text.png", "this is not an image, just some text\n"},
        {"truncated.png", png.substr(0, png.size() / 2)},
        {"header_only.png", png.substr(0, 60)},
        {"corrupt.png", corrupt},
        {"random.bin", std::string(4096, '\x37')},
    };
    for (const Bad& b : cases) {
        auto r = io::decode_image_file(write_bytes(b.name, b.bytes));
        EXPECT_FALSE(r.ok()) << b.name;
        if (!r.ok()) {
            EXPECT_FALSE(r.error().message.empty()) << b.name;
            EXPECT_TRUE(r.error().code == ErrorCode::unprocessable ||
                        r.error().code == ErrorCode::unsupported)
                << b.name << ": " << r.error().message;
        }
        EXPECT_FALSE(io::decode_image_memory(b.bytes).ok()) << b.name;
    }
    auto missing = io::decode_image_file((temp_dir() / "does-not-exist.png").string());
    ASSERT_FALSE(missing.ok());
    EXPECT_EQ(missing.error().code, ErrorCode::not_found);
}

// A file takes the upload's path: a format uploads refuse (here Targa and Radiance HDR, which
// OpenImageIO reads) is refused from a file too, with the upload's words; so is a PNG cut short,
// before the decoder sees it. A directory is said to be one, not a missing file.
TEST(Decode, FilesAreRefusedAsUploadsAre) {
    const auto px = pattern(16, 16, 3);
    for (const char* name : {"rgb.tga", "rgb.hdr"}) {
        const std::string path = write_with_oiio(name, 16, 16, 3, OIIO::TypeDesc::UINT8, px);
        const auto from_file = io::decode_image_file(path);
        const auto from_memory = io::decode_image_memory(io::read_file(path).value());
        ASSERT_FALSE(from_file.ok()) << name;
        ASSERT_FALSE(from_memory.ok()) << name;
        EXPECT_EQ(from_file.error().code, ErrorCode::unsupported) << name;
        EXPECT_EQ(from_file.error().message, from_memory.error().message) << name;
    }
    const std::string png = io::read_file(test::exemplar_path("etr_sand01.png")).value();
    const std::string cut = png.substr(0, png.size() - 100);
    const auto from_file = io::decode_image_file(write_bytes("cut.png", cut));
    ASSERT_FALSE(from_file.ok());
    EXPECT_EQ(from_file.error().message, io::decode_image_memory(cut).error().message);
    EXPECT_NE(from_file.error().message.find("truncated"), std::string::npos);

    const auto dir = io::decode_image_file(temp_dir().string());
    ASSERT_FALSE(dir.ok());
    EXPECT_EQ(dir.error().code, ErrorCode::invalid_argument);
    EXPECT_NE(dir.error().message.find("not a regular file"), std::string::npos);
}

// A file larger than any image within the pixel budget is refused before it is read.
TEST(Decode, AFileLargerThanTheBudgetAllowsIsNotRead) {
    io::DecodeLimits tiny;
    tiny.max_pixels = 1;
    const std::string path = write_bytes("big.png", std::string((16U << 20) + 4096, '\0'));
    const auto r = io::decode_image_file(path, tiny);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::too_large) << r.error().message;
}

TEST(Encode, WritesPng8Png16AndExrAtomically) {
    core::Image img = test::white_noise(20, 10, 3, 1);
    for (auto& v : img.data) v = 0.5f + 0.1f * v;
    for (auto [name, enc] : {std::pair{"o8.png", io::Encoding::png8},
                             {"o16.png", io::Encoding::png16},
                             {"of.exr", io::Encoding::exr}}) {
        const std::string path = (temp_dir() / name).string();
        ASSERT_TRUE(io::encode_image_file(img, path, enc).ok());
        auto back = io::decode_image_file(path);
        ASSERT_TRUE(back.ok());
        const double tol = enc == io::Encoding::exr     ? 0.0
                           : enc == io::Encoding::png16 ? 1e-4
                                                        : 3e-3;
        EXPECT_LE(test::max_abs_diff(back.value(), img), tol) << name;
    }
    for (const auto& e : fs::directory_iterator(temp_dir()))
        EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
    EXPECT_FALSE(io::encode_image_file(img, "/nonexistent-dir/x.png", io::Encoding::png8).ok());
}

// Encoded in memory (the encoder writes into the returned string, seeking back where EXR fills
// in its offset table): the pixels back for every format, EXR's bytes those of the file, and an
// image larger than the recycled buffer it is written into.
TEST(Encode, InMemoryEqualsTheFileAndDecodesBack) {
    for (int side : {7, 300}) {
        core::Image img = test::white_noise(side, side + 3, 3, 2);
        for (auto& v : img.data) v = std::clamp(0.5f + 0.1f * v, 0.0f, 1.0f);
        for (auto [name, enc] : {std::pair{"m8.png", io::Encoding::png8},
                                 {"m16.png", io::Encoding::png16},
                                 {"mf.exr", io::Encoding::exr}}) {
            SCOPED_TRACE(std::string(name) + " " + std::to_string(side));
            const std::string path = (temp_dir() / name).string();
            ASSERT_TRUE(io::encode_image_file(img, path, enc).ok());
            auto memory = io::encode_image_memory(img, enc);
            ASSERT_TRUE(memory.ok());
            // PNG files take the default zlib level, tiles the stored one: only EXR compares.
            if (enc == io::Encoding::exr) {
                EXPECT_TRUE(memory.value() == io::read_file(path).value());
            }
            auto back = io::decode_image_memory(memory.value());
            ASSERT_TRUE(back.ok());
            const double tol = enc == io::Encoding::exr     ? 0.0
                               : enc == io::Encoding::png16 ? 1e-4
                                                            : 3e-3;
            EXPECT_LE(test::max_abs_diff(back.value(), img), tol);
            io::recycle_encoded(std::move(memory.value()));
        }
    }
}

// Inputs the fuzzer (tests/fuzz) found crashing or leaking in OpenImageIO 2.4's readers: each is
// now refused before that reader code runs, or decoded without touching it. (The asan preset
// turns a regression back into a crash; this build checks the answers.)
TEST(Decode, FuzzRegressionsAreRefusedCleanly) {
    const fs::path dir = fs::path(TEXTOND_FUZZ_REGRESSIONS);
    int seen = 0;
    for (const auto& entry : fs::directory_iterator(dir)) {
        const std::string bytes = io::read_file(entry.path().string()).value();
        SCOPED_TRACE(entry.path().filename().string());
        auto r = io::decode_image_memory(bytes);
        ++seen;
        if (!r) {
            EXPECT_TRUE(r.error().code == ErrorCode::unprocessable ||
                        r.error().code == ErrorCode::unsupported)
                << r.error().message;
        }
    }
    EXPECT_GE(seen, 2);
}

TEST(Decode, TruncatedPngIsRefusedBeforeTheDecoder) {
    const std::string png = io::read_file(test::exemplar_path("etr_sand01.png")).value();
    auto whole = io::decode_image_memory(png);
    ASSERT_TRUE(whole);
    for (std::size_t cut : {png.size() - 1, png.size() - 12, png.size() / 2, std::size_t{40}}) {
        auto r = io::decode_image_memory(png.substr(0, cut));
        ASSERT_FALSE(r) << cut;
        EXPECT_EQ(r.error().code, ErrorCode::unprocessable);
        EXPECT_NE(r.error().message.find("truncated"), std::string::npos) << r.error().message;
    }
}

TEST(Decode, JpegMetadataIsStrippedAndThePixelsKept) {
    // A JPEG with Exif (APP1) and a comment decodes to the same pixels as without them.
    const core::Image u = test::crop(test::load_exemplar("etr_sand01.png"), 64, 48);
    const std::string path = test::temp_path("meta.jpg");
    {
        auto out = OIIO::ImageOutput::create(path);
        OIIO::ImageSpec spec(u.width, u.height, 3, OIIO::TypeDesc::UINT8);
        spec.attribute("ImageDescription", "a comment that lands in a metadata segment");
        spec.attribute("Exif:UserComment", "more metadata");
        std::vector<unsigned char> px(u.plane_size() * 3);
        for (std::size_t k = 0; k < u.plane_size(); ++k)
            for (int c = 0; c < 3; ++c)
                px[k * 3 + c] = static_cast<unsigned char>(u.plane(c)[k] * 255.0f + 0.5f);
        ASSERT_TRUE(out->open(path, spec) && out->write_image(OIIO::TypeDesc::UINT8, px.data()) &&
                    out->close());
    }
    const std::string jpeg = io::read_file(path).value();
    auto from_memory = io::decode_image_memory(jpeg);
    auto from_file = io::decode_image_file(path);
    ASSERT_TRUE(from_memory) << from_memory.error().message;
    ASSERT_TRUE(from_file);
    EXPECT_EQ(test::max_abs_diff(from_memory.value(), from_file.value()), 0.0);
    auto cut = io::decode_image_memory(jpeg.substr(0, 30));
    ASSERT_FALSE(cut);
    EXPECT_EQ(cut.error().code, ErrorCode::unprocessable);
}

// A progressive JPEG decodes; one with more than kMaxJpegScans scans is refused before libjpeg
// sees it. The bomb repeats a 10-byte scan of the file's own (an AC band of one component) before
// its end, as an attacker's 1 MB file held 100,000 of them.
TEST(Decode, AProgressiveJpegDecodesAndAScanBombIsRefused) {
    const core::Image u = test::crop(test::load_exemplar("etr_sand01.png"), 64, 48);
    const std::string path = test::temp_path("progressive.jpg");
    {
        auto out = OIIO::ImageOutput::create(path);
        OIIO::ImageSpec spec(u.width, u.height, 3, OIIO::TypeDesc::FLOAT);
        spec.attribute("jpeg:progressive", 1);
        ASSERT_TRUE(out->open(path, spec) &&
                    out->write_image(OIIO::TypeDesc::FLOAT, u.data.data(), sizeof(float) * 3) &&
                    out->close());
    }
    const std::string jpeg = io::read_file(path).value();
    std::size_t scans = 0, last = 0;
    for (std::size_t at = jpeg.find("\xff\xda"); at != std::string::npos;
         at = jpeg.find("\xff\xda", at + 2), ++scans)
        last = at;
    ASSERT_GT(scans, 1u) << "not progressive";
    ASSERT_LE(scans, io::kMaxJpegScans);
    auto ok = io::decode_image_memory(jpeg);
    ASSERT_TRUE(ok) << ok.error().message;
    EXPECT_EQ(ok.value().width, 64);

    const std::string scan =
        jpeg.substr(last, 2 + 256 * static_cast<unsigned char>(jpeg[last + 2]) +
                              static_cast<unsigned char>(jpeg[last + 3]));
    std::string bomb = jpeg.substr(0, jpeg.size() - 2); // without its EOI
    for (std::size_t k = scans; k <= io::kMaxJpegScans; ++k) bomb += scan;
    bomb += "\xff\xd9";
    auto refused = io::decode_image_memory(bomb);
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().code, ErrorCode::unprocessable);
    EXPECT_NE(refused.error().message.find(std::to_string(io::kMaxJpegScans + 1) + " scans"),
              std::string::npos)
        << refused.error().message;
    // An end-of-image pair inside a segment libjpeg skips (an APP0 here) ends nothing: the scans
    // after it are counted (a reviewing attacker's bypass).
    std::string hidden = bomb;
    hidden.insert(2, std::string("\xff\xe0\x00\x08XXXX\xff\xd9", 10));
    auto still = io::decode_image_memory(hidden);
    ASSERT_FALSE(still);
    EXPECT_NE(still.error().message.find(std::to_string(io::kMaxJpegScans + 1) + " scans"),
              std::string::npos)
        << still.error().message;
    // What follows the end of image is no scan of it (a motion photo's video, random bytes with
    // a start-of-scan marker every 64 kB on average): the same photo decodes.
    std::string trailed = jpeg;
    for (std::size_t k = 0; k <= io::kMaxJpegScans; ++k) trailed += scan + std::string(300, '\x5a');
    auto photo = io::decode_image_memory(trailed);
    ASSERT_TRUE(photo) << photo.error().message;
    EXPECT_EQ(test::max_abs_diff(photo.value(), ok.value()), 0.0);
}

TEST(Decode, ExrHeadersAreCheckedBeforeOpenExrAllocates) {
    core::Image u(64, 48, 3, 0.25f);
    const std::string exr = io::encode_image_memory(u, io::Encoding::exr).value();
    auto ok = io::decode_image_memory(exr);
    ASSERT_TRUE(ok) << ok.error().message;
    EXPECT_EQ(ok.value().width, 64);
    // Over the pixel budget: refused from the header (413), before OpenEXR reads on.
    io::DecodeLimits small;
    small.max_pixels = 64 * 48 - 1;
    auto big = io::decode_image_memory(exr, small);
    ASSERT_FALSE(big);
    EXPECT_EQ(big.error().code, ErrorCode::too_large);
    // An attribute declaring more bytes than the file has (the fuzzer's 2 GB string).
    std::string bomb = exr;
    const std::size_t name = bomb.find("channels");
    ASSERT_NE(name, std::string::npos);
    const std::size_t size_at = bomb.find('\0', name + 9) + 1; // after "chlist\0"
    for (int k = 0; k < 4; ++k) bomb[size_at + k] = static_cast<char>(k == 3 ? 0x70 : 0xff);
    auto refused = io::decode_image_memory(bomb);
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().code, ErrorCode::unprocessable);
    EXPECT_NE(refused.error().message.find("more than the file has"), std::string::npos)
        << refused.error().message;
}

namespace textond::test {
namespace {
// The same pixels are the same bytes whenever they are encoded: tiles carry strong ETags, so an
// encoder that stamps the time (OpenEXR's capDate) would give one ETag two bodies.
TEST(ImageEncode, SameBytesAcrossSeconds) {
    const core::Image im = crop(load_exemplar("etr_sand01.png"), 16, 16);
    const io::Encoding all[] = {io::Encoding::exr, io::Encoding::png8, io::Encoding::png16};
    std::vector<std::string> first;
    for (io::Encoding e : all) first.push_back(io::encode_image_memory(im, e).value());
    std::this_thread::sleep_for(std::chrono::milliseconds(1100));
    for (std::size_t i = 0; i < 3; ++i)
        EXPECT_TRUE(first[i] == io::encode_image_memory(im, all[i]).value())
            << io::extension_of(all[i]);
}
} // namespace
} // namespace textond::test

namespace {

// A 16-channel float TIFF of w x h in tiles of `tile` (0: scanlines), zip-compressed: channel c
// of pixel (x, y) is (x + 3 y + 7 c) mod 101 / 100.
std::string many_channel_tiff(int w, int h, int tile) {
    OIIO::ImageSpec spec(w, h, 16, OIIO::TypeDesc::FLOAT);
    if (tile > 0) spec.tile_width = spec.tile_height = tile;
    spec.attribute("compression", "zip");
    std::vector<float> px(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 16);
    for (std::size_t k = 0; k < px.size(); ++k) {
        const std::size_t p = k / 16, c = k % 16;
        const std::size_t x = p % static_cast<std::size_t>(w), y = p / static_cast<std::size_t>(w);
        px[k] = static_cast<float>((x + 3 * y + 7 * c) % 101) / 100.0f;
    }
    const std::string path = test::temp_path("channels" + std::to_string(tile) + ".tif");
    auto out = OIIO::ImageOutput::create(path);
    EXPECT_TRUE(out && out->open(path, spec) &&
                out->write_image(OIIO::TypeDesc::FLOAT, px.data()) && out->close());
    return io::read_file(path).value();
}

long peak_rss_mib() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u.ru_maxrss / 1024;
}

} // namespace

// A tiled file is read a row of tiles at a time, and only the channels kept: a 1024 x 1024 TIFF
// of 16 float channels in 256 x 256 tiles decodes to the scanline file's pixels within a few MB
// beyond its planes (it had held all 16 channels of the whole image: 64 MB more here, 3.3 GiB
// for a 4096 x 4096 upload of 1 MB). A file whose one tile the reader would inflate beyond
// max_reader_chunk is refused from its header, before a pixel.
TEST(Decode, ManyChannelTilesAreReadInBandsAndHugeTilesRefused) {
    const std::string scanlines = many_channel_tiff(1024, 1024, 0);
    const std::string tiled = many_channel_tiff(1024, 1024, 256);
    auto plain = io::decode_image_memory(scanlines);
    ASSERT_TRUE(plain) << plain.error().message;
    const long before = peak_rss_mib();
    auto banded = io::decode_image_memory(tiled);
    const long grown = peak_rss_mib() - before;
    ASSERT_TRUE(banded) << banded.error().message;
    EXPECT_EQ(banded.value().channels, 3);
    EXPECT_EQ(test::max_abs_diff(banded.value(), plain.value()), 0.0);
    EXPECT_FLOAT_EQ(banded.value().at(2, 5, 1), static_cast<float>((5 + 3 + 14) % 101) / 100.0f);
    EXPECT_LT(grown, 24) << "MiB grown beyond the scanline decode's peak";
    auto header = io::image_header_memory(tiled);
    ASSERT_TRUE(header);
    // 12 MiB of planes, a band of 256 rows of 3 channels (3 MiB) and a 4 MiB tile.
    EXPECT_EQ(header.value().decode_bytes, (12u << 20) + (3u << 20) + (4u << 20));

    const std::string one_tile = many_channel_tiff(512, 512, 512); // 16 MiB inflated at once
    io::DecodeLimits small;
    small.max_reader_chunk = std::uint64_t{8} << 20;
    for (auto refused : {io::image_header_memory(one_tile, small).error(),
                         io::decode_image_memory(one_tile, small).error()}) {
        EXPECT_EQ(refused.code, ErrorCode::unprocessable);
        EXPECT_NE(refused.message.find("tiles of 512x512 with 16 channels: 16 MiB"),
                  std::string::npos)
            << refused.message;
    }
    EXPECT_TRUE(io::decode_image_memory(one_tile)) << "within the default limit";
}
