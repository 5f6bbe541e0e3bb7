#include "core/elevation_encoding.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace textond::core {
namespace {

// What an 8-bit encoder stores: round(v * 255).
int byte_of(float v) {
    return static_cast<int>(std::lround(v * 255.0f));
}

class ElevationEncodingTest : public ::testing::TestWithParam<ElevationEncoding> {};

TEST_P(ElevationEncodingTest, DecodesToTheMetresWithinHalfAStep) {
    const ElevationEncoding e = GetParam();
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> height(-2.0f, 3.0f); // noise leaves 0..1 too
    Image h(64, 64, 1);
    for (float& v : h.data) v = height(rng);
    const double scale = 731.5;
    const Image rgb = encode_elevation(h, e, scale);
    ASSERT_EQ(rgb.channels, 3);
    double worst = 0.0;
    for (int y = 0; y < h.height; ++y)
        for (int x = 0; x < h.width; ++x) {
            for (int c = 0; c < 3; ++c) // exactly a byte: k / 255
                ASSERT_FLOAT_EQ(rgb.at(c, x, y) * 255.0f,
                                static_cast<float>(byte_of(rgb.at(c, x, y))));
            const double metres = decode_elevation(
                byte_of(rgb.at(0, x, y)), byte_of(rgb.at(1, x, y)), byte_of(rgb.at(2, x, y)), e);
            worst = std::max(worst, std::abs(metres - static_cast<double>(h.at(0, x, y)) * scale));
        }
    // float heights carry ~1e-7 relative error: 2.2e3 m * 1.2e-7 = 3e-4 m at most.
    EXPECT_LE(worst, elevation_step(e) / 2 + 3e-4);
    EXPECT_GT(worst, elevation_step(e) / 8); // it is quantised, not exact by accident
}

TEST_P(ElevationEncodingTest, ClampsToItsRange) {
    const ElevationEncoding e = GetParam();
    Image h(2, 1, 1);
    h.at(0, 0, 0) = -1e6f;
    h.at(0, 1, 0) = 1e9f;
    const Image rgb = encode_elevation(h, e, 1.0);
    for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(byte_of(rgb.at(c, 0, 0)), 0);
        EXPECT_EQ(byte_of(rgb.at(c, 1, 0)), 255);
    }
    const double low = e == ElevationEncoding::terrarium ? -32768.0 : -10000.0;
    EXPECT_DOUBLE_EQ(decode_elevation(0, 0, 0, e), low);
}

INSTANTIATE_TEST_SUITE_P(Both, ElevationEncodingTest,
                         ::testing::Values(ElevationEncoding::terrarium, ElevationEncoding::mapbox),
                         [](const auto& p) { return elevation_encoding_name(p.param); });

// The formulas of the two specifications, on known values.
TEST(ElevationEncoding, KnownValues) {
    // terrarium: 0 m is (128, 0, 0); 100.5 m is 32868.5 = (128, 100, 128)
    EXPECT_DOUBLE_EQ(decode_elevation(128, 0, 0, ElevationEncoding::terrarium), 0.0);
    Image h(1, 1, 1, 100.5f);
    Image t = encode_elevation(h, ElevationEncoding::terrarium, 1.0);
    EXPECT_EQ(byte_of(t.at(0, 0, 0)), 128);
    EXPECT_EQ(byte_of(t.at(1, 0, 0)), 100);
    EXPECT_EQ(byte_of(t.at(2, 0, 0)), 128);
    // mapbox: 0 m is code 100000 = (1, 134, 160)
    Image m = encode_elevation(Image(1, 1, 1, 0.0f), ElevationEncoding::mapbox, 1.0);
    EXPECT_EQ(byte_of(m.at(0, 0, 0)), 1);
    EXPECT_EQ(byte_of(m.at(1, 0, 0)), 134);
    EXPECT_EQ(byte_of(m.at(2, 0, 0)), 160);
    EXPECT_EQ(parse_elevation_encoding("mapbox"), ElevationEncoding::mapbox);
    EXPECT_FALSE(parse_elevation_encoding("Terrarium"));
}

} // namespace
} // namespace textond::core
