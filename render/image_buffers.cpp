#include "render/image_buffers.h"

#include <mutex>
#include <utility>
#include <vector>

namespace textond::render {

namespace {
std::mutex g_mutex;
std::vector<std::vector<float>>& spares() {
    static std::vector<std::vector<float>> v;
    return v;
}
} // namespace

core::Image take_image(int width, int height, int channels) {
    const std::size_t n = static_cast<std::size_t>(width) * height * channels;
    std::vector<float> buffer;
    {
        std::lock_guard lock(g_mutex);
        auto& s = spares();
        for (std::size_t i = 0; i < s.size(); ++i)
            if (s[i].capacity() >= n) {
                buffer = std::move(s[i]);
                s.erase(s.begin() + static_cast<std::ptrdiff_t>(i));
                break;
            }
    }
    if (buffer.capacity() < n) return core::Image(width, height, channels);
    core::Image out;
    out.width = width;
    out.height = height;
    out.channels = channels;
    out.data = std::move(buffer);
    out.data.resize(n);
    return out;
}

void recycle_image(core::Image&& image) {
    std::vector<float> buffer = std::move(image.data);
    image = core::Image();
    if (buffer.capacity() * sizeof(float) > kMaxSpareBytes) return;
    std::lock_guard lock(g_mutex);
    if (spares().size() < kMaxSpares) spares().push_back(std::move(buffer));
}

} // namespace textond::render
