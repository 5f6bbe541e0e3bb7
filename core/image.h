#pragma once
// A planar float image: channel c, row y, column x at data[(c * height + y) * width + x].
// Planar because every analysis step works on one channel plane at a time (FFT per channel).
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace textond::core {

struct Image {
    int width = 0;
    int height = 0;
    int channels = 0;
    std::vector<float> data;
    // Or, only where a caller asked a renderer for 8-bit bytes (render::NoiseRequest::bytes) and
    // the backend read back only those (a GL tile): the values as bytes, pixel after pixel, its
    // channels interleaved, and `data` empty. They are what the PNG, WebP and AVIF encoders take,
    // so neither side converts to floats and back (render/README.md, "8-bit tiles").
    std::vector<std::uint8_t> bytes;

    Image() = default;
    Image(int w, int h, int c, float fill = 0.0f) : width(w), height(h), channels(c) {
        if (w < 0 || h < 0 || c < 0) throw std::invalid_argument("Image: negative size");
        data.assign(static_cast<std::size_t>(w) * h * c, fill);
    }

    std::size_t plane_size() const { return static_cast<std::size_t>(width) * height; }
    float* plane(int c) { return data.data() + plane_size() * c; }
    const float* plane(int c) const { return data.data() + plane_size() * c; }
    float& at(int c, int x, int y) { return plane(c)[static_cast<std::size_t>(y) * width + x]; }
    float at(int c, int x, int y) const {
        return plane(c)[static_cast<std::size_t>(y) * width + x];
    }
    bool empty() const { return data.empty() && bytes.empty(); }
    bool is_bytes() const { return !bytes.empty(); }
};

} // namespace textond::core
