#pragma once
// A planar float image: channel c, row y, column x at data[(c * height + y) * width + x].
// Planar because every analysis step works on one channel plane at a time (FFT per channel).
#include <cstddef>
#include <stdexcept>
#include <vector>

namespace textond::core {

struct Image {
    int width = 0;
    int height = 0;
    int channels = 0;
    std::vector<float> data;

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
    bool empty() const { return data.empty(); }
};

} // namespace textond::core
