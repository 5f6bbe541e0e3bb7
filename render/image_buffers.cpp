#include "render/image_buffers.h"

#include <cstdint>
#include <mutex>
#include <utility>
#include <vector>

#include <sys/mman.h>

namespace textond::render {

namespace {
std::mutex g_mutex;
std::vector<std::vector<float>>& spares() {
    static std::vector<std::vector<float>> v;
    return v;
}
// A frame too large for the pool is a fresh mapping that its zero fill faults in page by page: on
// 4 kB pages a 4K RGB float frame (100 MB) took 108 ms here, 40 ms on 2 MB pages, where the system
// gives them on request (transparent huge pages in `madvise` mode, Debian's default).
core::Image fresh_image(int width, int height, int channels, std::size_t n) {
    if (width < 0 || height < 0 || channels < 0) return core::Image(width, height, channels);
    constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
    core::Image out;
    out.width = width;
    out.height = height;
    out.channels = channels;
    out.data.reserve(n);
    const auto begin = reinterpret_cast<std::uintptr_t>(out.data.data());
    const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1);
    const std::uintptr_t end = (begin + n * sizeof(float)) & ~(kHuge - 1);
    if (end > first) // advice only: where it is refused, small pages as before
        madvise(reinterpret_cast<char*>(out.data.data()) + (first - begin), end - first,
                MADV_HUGEPAGE);
    out.data.assign(n, 0.0f);
    return out;
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
    if (buffer.capacity() < n) return fresh_image(width, height, channels, n);
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
