#include "core/working_window.h"

#include <algorithm>
#include <cstring>

namespace textond::core {

bool is_windowed(int width, int height, int side) {
    return side > 0 && (width > side || height > side);
}

Image working_window(const Image& u, int side) {
    if (!is_windowed(u.width, u.height, side)) return {};
    return centred_part(u, std::min(u.width, side), std::min(u.height, side));
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
