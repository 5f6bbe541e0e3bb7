#include "server/io/quantise.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace textond::io {
namespace {

// The rule as the PNG encoder has always rounded, one value at a time.
template <class T> T reference(float v) {
    if (std::isnan(v)) return 0;
    return static_cast<T>(std::clamp(v, 0.0f, 1.0f) * std::numeric_limits<T>::max() + 0.5f);
}

// Every step boundary of the type (k + 0.5) / max, just either side of it, and what must clamp.
template <class T> std::vector<float> values() {
    constexpr float kMax = std::numeric_limits<T>::max();
    std::vector<float> v = {-1.0f,
                            -1e-7f,
                            0.0f,
                            1.0f,
                            1.0f + 1e-6f,
                            7.0f,
                            3e9f,
                            -3e9f,
                            std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(),
                            std::numeric_limits<float>::quiet_NaN()};
    for (int k = 0; k <= static_cast<int>(kMax); ++k) {
        const float step = static_cast<float>(k);
        const float mid = (step + 0.5f) / kMax;
        v.insert(v.end(), {step / kMax, mid, std::nextafter(mid, 0.0f), std::nextafter(mid, 2.0f)});
    }
    return v;
}

template <class T> void check_all_channel_counts() {
    const std::vector<float> base = values<T>();
    const std::size_t n = base.size() + 37; // crosses the chunks, and not a multiple of them
    std::vector<std::vector<float>> planes(4, std::vector<float>(n));
    for (int c = 0; c < 4; ++c)
        for (std::size_t k = 0; k < n; ++k)
            planes[c][k] = base[(k + static_cast<std::size_t>(c) * 13) % base.size()];
    for (int nc = 1; nc <= 4; ++nc) {
        SCOPED_TRACE(nc);
        const float* p[4] = {planes[0].data(), planes[1].data(), planes[2].data(),
                             planes[3].data()};
        std::vector<T> out(n * nc, 0x5a);
        quantise_interleaved(p, nc, n, out.data());
        for (std::size_t k = 0; k < n; ++k)
            for (int c = 0; c < nc; ++c)
                ASSERT_EQ(out[k * nc + c], reference<T>(planes[c][k])) << k << " " << planes[c][k];
    }
}

TEST(Quantise, EightBitsRoundAsThePngEncoderAlwaysHas) {
    check_all_channel_counts<std::uint8_t>();
}

TEST(Quantise, SixteenBitsRoundAsThePngEncoderAlwaysHas) {
    check_all_channel_counts<std::uint16_t>();
}

TEST(Quantise, APlaneNamedThreeTimesIsGreyAsRgb) {
    const std::vector<float> grey = {0.0f, 0.25f, 0.5f, 1.0f, 2.0f};
    const float* p[3] = {grey.data(), grey.data(), grey.data()};
    std::vector<std::uint8_t> out(grey.size() * 3);
    quantise_interleaved(p, 3, grey.size(), out.data());
    const std::vector<std::uint8_t> want = {0,   0,   0,   64,  64,  64,  128, 128,
                                            128, 255, 255, 255, 255, 255, 255};
    EXPECT_EQ(out, want);
}

TEST(Quantise, MoreThanFourChannelsAreRefused) {
    const std::vector<float> one(4, 0.5f);
    const float* p[5] = {one.data(), one.data(), one.data(), one.data(), one.data()};
    std::vector<std::uint8_t> out(20);
    EXPECT_THROW(quantise_interleaved(p, 5, 4, out.data()), std::invalid_argument);
}

} // namespace
} // namespace textond::io
