#pragma once
// When a render gives up before its end, so that work nobody waits for does not delay the tiles
// behind it: the client left, or the request's deadline passed. Backends poll stop() between blocks
// of work, from any thread, and answer ErrorCode::cancelled; the first "stop" sticks.
#include "core/result.h"

#include <atomic>
#include <chrono>
#include <functional>

namespace textond::render {

class Cancel {
public:
    using Clock = std::chrono::steady_clock;
    Cancel() = default; // never stops
    // `gone` says whether the client left; it is polled at most every `poll_every` (a system
    // call for a socket), by one thread at a time.
    Cancel(Clock::time_point deadline, std::function<bool()> gone,
           Clock::duration poll_every = std::chrono::milliseconds(20))
        : m_deadline(deadline), m_gone(std::move(gone)), m_poll_every(poll_every) {}
    Cancel(const Cancel&) = delete;
    Cancel& operator=(const Cancel&) = delete;

    bool stop() const;
    // Why it stopped: the deadline passed (rather than the client leaving).
    bool deadline_passed() const { return m_deadline_passed.load(std::memory_order_relaxed); }

private:
    Clock::time_point m_deadline = Clock::time_point::max();
    std::function<bool()> m_gone;
    Clock::duration m_poll_every{};
    mutable std::atomic<bool> m_stopped{false}, m_deadline_passed{false};
    mutable std::atomic<Clock::rep> m_next_poll{0};
};

// Whether `c` (which may be absent) says stop.
inline bool stopped(const Cancel* c) {
    return c && c->stop();
}

// The error of work that `c` stopped: `what` ("the render") passed its deadline, or its client
// left.
Error abandoned(const Cancel* c, const char* what);

} // namespace textond::render
