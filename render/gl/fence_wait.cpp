#include "render/gl/fence_wait.h"

#include <algorithm>

namespace textond::render::gl {

using std::chrono::microseconds;

FenceWait await_fence(const std::function<FenceState()>& poll, microseconds expected,
                      const std::function<void(microseconds)>& sleep) {
    FenceWait w{0, microseconds{0}, FenceState::pending};
    auto ask = [&] {
        ++w.polls;
        w.state = poll();
        return w.state != FenceState::pending;
    };
    auto nap = [&](microseconds d) {
        sleep(d);
        w.slept += d;
    };
    if (ask()) return w;
    if (expected.count() > 0) nap(expected * 3 / 4);
    double step = std::max(50.0, static_cast<double>(expected.count()) / 20.0);
    while (!ask()) {
        step = std::min(step, 1000.0);
        nap(microseconds{static_cast<long long>(step)});
        step *= 1.25;
    }
    return w;
}

void PassTimeEstimate::measured(double gpu_ms, std::size_t pixels) {
    if (!(gpu_ms > 0) || pixels == 0) return;
    m_recent[m_count++ % 16] = gpu_ms * 1e6 / static_cast<double>(pixels);
}

microseconds PassTimeEstimate::of(std::size_t pixels) const {
    if (m_count == 0) return microseconds{0};
    const double* end = m_recent + std::min(m_count, 16);
    const double ns = *std::min_element(m_recent, end);
    return microseconds{static_cast<long long>(ns * static_cast<double>(pixels) / 1e3)};
}

} // namespace textond::render::gl
