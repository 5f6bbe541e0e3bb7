#pragma once
// Waiting for a GL pass's fence without spinning a core. NVIDIA's glClientWaitSync spins (with
// sched_yield) for the whole wait: on a GPU host every lane waiting for its pass kept a core busy,
// CPU time the cold tiles' host cost counted. The fence is polled with a zero timeout instead,
// the thread sleeping most of the pass's expected time first and then in short steps. No GL
// here: the backend passes its poll and the test a fake one.
#include <chrono>
#include <cstddef>
#include <functional>

namespace textond::render::gl {

enum class FenceState { signalled, pending, failed };

struct FenceWait {
    int polls = 0;                   // how many times the fence was asked
    std::chrono::microseconds slept; // in total
    FenceState state = FenceState::pending;
};

// Polls until the fence is signalled or failed. `expected` is how long the pass has left by the
// backend's estimate (zero or less: none, poll at once and then in steps). The first sleep is
// three quarters of it; then a step of a twentieth of it (50 us at least), growing by a quarter
// each poll up to 1 ms, so a pass far longer than estimated is asked about 1,000 times a second,
// and one that ends as estimated is answered within a step of its end.
FenceWait await_fence(const std::function<FenceState()>& poll, std::chrono::microseconds expected,
                      const std::function<void(std::chrono::microseconds)>& sleep);

// The backend's estimate of a pass's GPU time: the fewest nanoseconds a pixel of the last 16
// passes measured. Passes differ 10-100x a pixel (a mix of 64 levels, a limit level): the fewest
// keeps a cheap pass from sleeping through an expensive one's average, at the cost of a few more
// polls of an expensive one.
class PassTimeEstimate {
public:
    void measured(double gpu_ms, std::size_t pixels);
    std::chrono::microseconds of(std::size_t pixels) const;

private:
    double m_recent[16] = {};
    int m_count = 0; // passes measured
};

} // namespace textond::render::gl
