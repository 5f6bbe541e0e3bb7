#include "server/io/image_io.h"
#include "server/io/upload_bytes.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <zlib.h>

#include <string>

using namespace textond;

namespace {

std::string png_chunk(const std::string& type, const std::string& data) {
    const auto be32 = [](std::uint32_t v) {
        return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                           static_cast<char>(v >> 8), static_cast<char>(v)};
    };
    const std::string body = type + data;
    const auto crc = static_cast<std::uint32_t>(
        crc32(0, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size())));
    return be32(static_cast<std::uint32_t>(data.size())) + body + be32(crc);
}

std::string deflated(std::size_t n) {
    const std::string plain(n, 'A');
    uLongf size = compressBound(static_cast<uLong>(n));
    std::string out(size, '\0');
    compress2(reinterpret_cast<Bytef*>(out.data()), &size,
              reinterpret_cast<const Bytef*>(plain.data()), static_cast<uLong>(n), 9);
    out.resize(size);
    return out;
}

long peak_rss_kib() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u.ru_maxrss;
}

} // namespace

// A PNG's text chunks never reach the decoder: 60 zTXt chunks and an iTXt of 4 MB each once
// inflated (a 3 MB upload of 400 such chunks had taken 3 GiB on open), and a tEXt, put after the
// IHDR of a real PNG, come out as that PNG byte for byte, which decodes to the same pixels within
// a few MB of memory.
TEST(UploadBytes, PngTextChunksNeverReachTheDecoder) {
    const core::Image u = test::crop(test::load_exemplar("etr_sand01.png"), 32, 24);
    auto encoded = io::encode_image_memory(u, io::Encoding::png8);
    ASSERT_TRUE(encoded);
    const std::string& png = encoded.value();
    EXPECT_TRUE(io::png_without_text(png).empty()) << "a PNG without text is used as it is";

    const std::string inflates = deflated(std::size_t{4} << 20);
    std::string text = png_chunk("tEXt", std::string("Comment\0hello", 13));
    for (int k = 0; k < 60; ++k)
        text += png_chunk("zTXt", "k" + std::to_string(k) + std::string(2, '\0') + inflates);
    text += png_chunk("iTXt", std::string("XML\0\1\0\0\0", 8) + inflates);
    constexpr std::size_t kAfterIhdr = 8 + 25;
    ASSERT_EQ(png.substr(12, 4), "IHDR");
    const std::string bomb = png.substr(0, kAfterIhdr) + text + png.substr(kAfterIhdr);
    EXPECT_EQ(io::png_without_text(bomb), png);

    const long before = peak_rss_kib();
    auto header = io::image_header_memory(bomb);
    auto decoded = io::decode_image_memory(bomb);
    const long grown_mib = (peak_rss_kib() - before) / 1024;
    ASSERT_TRUE(header) << header.error().message;
    ASSERT_TRUE(decoded) << decoded.error().message;
    EXPECT_EQ(header.value().width, 32);
    auto plain = io::decode_image_memory(png);
    ASSERT_TRUE(plain);
    EXPECT_EQ(test::max_abs_diff(decoded.value(), plain.value()), 0.0);
    EXPECT_LT(grown_mib, 32) << "the text was inflated: 244 MB of it";
}
