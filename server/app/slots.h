#pragma once
// When heavy work may start: every decode, render, resample, encode, body parse and
// rasterisation runs while holding a slot; a request waits for one at most a set time (then
// 429) and is dropped while waiting if its client left.
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>

namespace textond::app {

// First come, first served slots for heavy work of one kind (the service keeps one set for
// renders and encodes, one for decoding uploads), waking exactly the next waiter: a shared
// condition variable would wake every waiter on each release, and that storm preempts the
// renders (tail latency x10 when it was one).
class WorkSlots {
public:
    enum class Admit { granted, busy, gone };
    WorkSlots(int n, std::size_t max_waiters) : m_free(n < 1 ? 1 : n), m_max_waiters(max_waiters) {}
    // Waits at most `max_wait` (busy), or until `gone()` says the client left (checked every
    // 100 ms). More than max_waiters waiting: busy at once.
    Admit acquire(std::chrono::milliseconds max_wait, const std::function<bool()>& gone = {});
    void release();
    void add(int n); // n more slots (at start)
    std::size_t waiting() const;
    int free() const; // slots not held now

private:
    struct Waiter {
        std::condition_variable cv;
        bool granted = false;
    };
    mutable std::mutex m_mutex;
    int m_free;
    const std::size_t m_max_waiters;
    std::deque<Waiter*> m_waiters;
};

// Holds a granted slot for a scope.
class SlotGuard {
public:
    SlotGuard() = default;
    explicit SlotGuard(WorkSlots* slots) : m_slots(slots) {}
    SlotGuard(SlotGuard&& o) noexcept : m_slots(o.m_slots) { o.m_slots = nullptr; }
    SlotGuard& operator=(SlotGuard&&) = delete;
    ~SlotGuard() {
        if (m_slots) m_slots->release();
    }

private:
    WorkSlots* m_slots = nullptr;
};

} // namespace textond::app
