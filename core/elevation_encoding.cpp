#include "core/elevation_encoding.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace textond::core {

std::optional<ElevationEncoding> parse_elevation_encoding(const std::string& name) {
    if (name == "terrarium") return ElevationEncoding::terrarium;
    if (name == "mapbox") return ElevationEncoding::mapbox;
    return std::nullopt;
}

const char* elevation_encoding_name(ElevationEncoding e) {
    return e == ElevationEncoding::terrarium ? "terrarium" : "mapbox";
}

double elevation_step(ElevationEncoding e) {
    return e == ElevationEncoding::terrarium ? 1.0 / 256.0 : 0.1;
}

namespace {

// The 24-bit code of `metres`, rounded to the nearest step and clamped to the range.
std::uint32_t code_of(double metres, ElevationEncoding e) {
    constexpr double kMax = 16777215.0; // 2^24 - 1
    const double code =
        e == ElevationEncoding::terrarium ? (metres + 32768.0) * 256.0 : (metres + 10000.0) * 10.0;
    if (!(code > 0.0)) return 0; // NaN too
    return static_cast<std::uint32_t>(std::min(kMax, std::nearbyint(code)));
}

} // namespace

Image encode_elevation(const Image& height, ElevationEncoding e, double height_scale) {
    Image out(height.width, height.height, 3);
    const float* h = height.plane(0);
    float* r = out.plane(0);
    float* g = out.plane(1);
    float* b = out.plane(2);
    for (std::size_t i = 0; i < height.plane_size(); ++i) {
        const std::uint32_t code = code_of(static_cast<double>(h[i]) * height_scale, e);
        r[i] = static_cast<float>((code >> 16) & 255U) / 255.0f;
        g[i] = static_cast<float>((code >> 8) & 255U) / 255.0f;
        b[i] = static_cast<float>(code & 255U) / 255.0f;
    }
    return out;
}

double decode_elevation(int r, int g, int b, ElevationEncoding e) {
    if (e == ElevationEncoding::terrarium) return r * 256.0 + g + b / 256.0 - 32768.0;
    return -10000.0 + (r * 65536.0 + g * 256.0 + b) * 0.1;
}

} // namespace textond::core
