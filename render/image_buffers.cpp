#include "render/image_buffers.h"

#include <cstdint>
#include <mutex>
#include <stdexcept>
#include <utility>
#include <vector>

#include <sys/mman.h>

namespace textond::render {

namespace {
std::mutex g_mutex;
template <class T> std::vector<std::vector<T>>& spares() {
    static std::vector<std::vector<T>> v;
    return v;
}

std::size_t g_held = 0; // bytes in both pools

// The first spare of at least n values, or an empty buffer.
template <class T> std::vector<T> take_spare(std::size_t n) {
    std::lock_guard lock(g_mutex);
    auto& s = spares<T>();
    for (std::size_t i = 0; i < s.size(); ++i)
        if (s[i].capacity() >= n) {
            std::vector<T> buffer = std::move(s[i]);
            s.erase(s.begin() + static_cast<std::ptrdiff_t>(i));
            g_held -= buffer.capacity() * sizeof(T);
            return buffer;
        }
    return {};
}

template <class T> void give_spare(std::vector<T>&& buffer) {
    const std::size_t size = buffer.capacity() * sizeof(T);
    if (size == 0 || size > kMaxSpareBytes) return;
    std::lock_guard lock(g_mutex);
    if (spares<T>().size() >= kMaxSpares || g_held + size > kMaxSpares * kMaxSpareBytes) return;
    g_held += size;
    spares<T>().push_back(std::move(buffer));
}

// A frame too large for the pool is a fresh mapping that its zero fill faults in page by page: on
// 4 kB pages a 4K RGB float frame (100 MB) took 108 ms here, 40 ms on 2 MB pages, where the system
// gives them on request (transparent huge pages in `madvise` mode, Debian's default). A 4K frame's
// 8-bit bytes (25 MB) fault the same way: the kernel's page clearing was the largest part of its
// readback copy (tests/bench/readback_bench).
template <class T> std::vector<T> fresh_buffer(std::size_t n) {
    constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
    std::vector<T> out;
    out.reserve(n);
    const auto begin = reinterpret_cast<std::uintptr_t>(out.data());
    const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1);
    const std::uintptr_t end = (begin + n * sizeof(T)) & ~(kHuge - 1);
    if (end > first) // advice only: where it is refused, small pages as before
        madvise(reinterpret_cast<char*>(out.data()) + (first - begin), end - first, MADV_HUGEPAGE);
    out.assign(n, T{});
    return out;
}

core::Image fresh_image(int width, int height, int channels, std::size_t n) {
    if (width < 0 || height < 0 || channels < 0) return core::Image(width, height, channels);
    core::Image out;
    out.width = width;
    out.height = height;
    out.channels = channels;
    out.data = fresh_buffer<float>(n);
    return out;
}

} // namespace

core::Image take_image(int width, int height, int channels) {
    const std::size_t n = static_cast<std::size_t>(width) * height * channels;
    std::vector<float> buffer = take_spare<float>(n);
    if (buffer.capacity() < n) return fresh_image(width, height, channels, n);
    core::Image out;
    out.width = width;
    out.height = height;
    out.channels = channels;
    out.data = std::move(buffer);
    out.data.resize(n);
    return out;
}

core::Image take_bytes_image(int width, int height, int channels) {
    core::Image out;
    if (width < 0 || height < 0 || channels < 0)
        throw std::invalid_argument("take_bytes_image: negative size");
    out.width = width;
    out.height = height;
    out.channels = channels;
    const std::size_t n = static_cast<std::size_t>(width) * height * channels;
    out.bytes = take_spare<std::uint8_t>(n);
    if (out.bytes.capacity() < n)
        out.bytes = fresh_buffer<std::uint8_t>(n);
    else
        out.bytes.resize(n);
    return out;
}

void recycle_image(core::Image&& image) {
    std::vector<float> floats = std::move(image.data);
    std::vector<std::uint8_t> bytes = std::move(image.bytes);
    image = core::Image();
    give_spare(std::move(floats));
    give_spare(std::move(bytes));
}

} // namespace textond::render
