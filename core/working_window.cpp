#include "core/working_window.h"

#include "core/fft2d.h"

#include <algorithm>
#include <cstring>

namespace textond::core {

int fast_fft_size(int n) {
    int m = n;
    while (m > 1 && !is_fft_friendly(m)) --m;
    return m;
}

int fast_side(int n, int least) {
    const int fast = fast_fft_size(n);
    return fast >= least ? fast : n;
}

std::array<int, 2> window_size(int width, int height, int side, int least) {
    if (side <= 0) return {width, height};
    return {fast_side(std::min(width, side), least), fast_side(std::min(height, side), least)};
}

bool is_windowed(int width, int height, int side) {
    return side > 0 && (width > side || height > side);
}

Image working_window(const Image& u, int side, int least) {
    const auto [w, h] = window_size(u.width, u.height, side, least);
    if (w == u.width && h == u.height) return {};
    return centred_part(u, w, h);
}

Image centred_part(const Image& u, int w, int h) {
    const int x0 = (u.width - w) / 2, y0 = (u.height - h) / 2;
    Image out(w, h, u.channels);
    for (int c = 0; c < u.channels; ++c)
        for (int y = 0; y < h; ++y)
            std::memcpy(&out.at(c, 0, y),
                        u.plane(c) + static_cast<std::size_t>(y0 + y) * u.width + x0,
                        static_cast<std::size_t>(w) * sizeof(float));
    return out;
}

} // namespace textond::core
