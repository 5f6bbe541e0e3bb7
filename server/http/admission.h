#pragma once
// Admission of heavy work: what a request may cost and when it may start, so that memory and CPU
// grow with the render slots, not with the number of clients (issue: 48 concurrent 4K regions
// once took 11 GB). Every decode, render, resample, encode, body parse and rasterisation runs
// while holding a slot; a request waits for one at most a set time (then 429), is dropped while
// waiting if its client left, and is refused up front (413) when its estimated CPU time is over
// the budget. Request bodies are read with exact limits for every transfer encoding, inside a
// process-wide budget of body bytes held in memory.
#include "api/requests.h"

#include <httplib.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string>

namespace textond::http {

// Estimated single-core CPU seconds, from per-unit costs measured with `textond bench render`
// on the CI machine (order 1, r 64): a kernel tap 1.5 ns, a (surface point, tap) 55 ns, a
// rasteriser pixel test 10 ns. Coarse on purpose: they only have to rank requests against the
// budget (README "Limits").
int taps_of_order(int order); // 1, 4 or 16
double noise_work_s(std::int64_t pixels, double mni, int order);
double surface_work_s(std::size_t points, double mni, int order);
double mesh_work_s(std::uint64_t raster_tests, std::int64_t pixels, double mni, int order);
// An analysis (core/texton_analysis.h) runs two FFTs of its working window (at most 1024 x 1024,
// core/working_window.h) a channel and an iteration (alternating projections, texton paper
// section 4), plus the periodic component, the model, the verdict and the marginals: kAnalysisNs
// of one core a window channel-pixel and iteration, with 8 iterations' worth of fixed work
// (fitted on a split of the shared photos, README "Limits"), and 10 ns a channel-pixel of the
// whole exemplar for its id (sha256 of its floats) and the window's copy. The upload is refused
// (413 work_too_large) before it is queued when over --max-request-cpu-s.
double analysis_work_s(int width, int height, int channels, int iterations);

// First come, first served slots, waking exactly the next waiter (a shared condition variable
// woke every waiter on each release, and that storm preempted the renders: tail latency x10).
class RenderSlots {
public:
    enum class Admit { granted, busy, gone };
    RenderSlots(int n, std::size_t max_waiters)
        : m_free(n < 1 ? 1 : n), m_max_waiters(max_waiters) {}
    // Waits at most `max_wait` (busy), or until `gone()` says the client left (checked every
    // 100 ms). More than max_waiters waiting: busy at once.
    Admit acquire(std::chrono::milliseconds max_wait, const std::function<bool()>& gone = {});
    void release();
    void add(int n); // n more slots (at start)
    std::size_t waiting() const;

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
    explicit SlotGuard(RenderSlots* slots) : m_slots(slots) {}
    SlotGuard(SlotGuard&& o) noexcept : m_slots(o.m_slots) { o.m_slots = nullptr; }
    SlotGuard& operator=(SlotGuard&&) = delete;
    ~SlotGuard() {
        if (m_slots) m_slots->release();
    }

private:
    RenderSlots* m_slots = nullptr;
};

// Bytes of request bodies held in memory by all requests at once.
class BodyBudget {
public:
    explicit BodyBudget(std::size_t bytes) : m_cap(bytes) {}
    bool reserve(std::size_t n);
    void release(std::size_t n) { m_used -= n; }
    std::size_t used() const { return m_used; }
    std::size_t cap() const { return m_cap; }

private:
    const std::size_t m_cap;
    std::atomic<std::size_t> m_used{0};
};

// Bytes of the budget held by one response until it has been written.
class BudgetLease {
public:
    BudgetLease(BodyBudget& budget, std::size_t n) : m_budget(budget), m_n(n) {}
    ~BudgetLease() { m_budget.release(m_n); }
    BudgetLease(const BudgetLease&) = delete;
    BudgetLease& operator=(const BudgetLease&) = delete;

private:
    BodyBudget& m_budget;
    std::size_t m_n;
};

// A request's body in memory, its bytes counted in the budget until it is dropped.
class Body {
public:
    explicit Body(BodyBudget& budget) : m_budget(budget) {}
    ~Body() { m_budget.release(m_reserved); }
    Body(const Body&) = delete;
    Body& operator=(const Body&) = delete;
    std::string bytes;
    // Appends, reserving budget in 1 MiB steps; false when over `limit` or the budget.
    bool append(const char* data, std::size_t n, std::size_t limit);
    // Counts n more bytes held elsewhere (multipart parts) against `limit` and the budget.
    bool count(std::size_t n, std::size_t limit);
    bool over_limit() const { return m_over_limit; }
    bool over_budget() const { return m_over_budget; }

private:
    BodyBudget& m_budget;
    std::size_t m_reserved = 0, m_counted = 0;
    bool m_over_limit = false, m_over_budget = false;
};

// Reads a non-multipart body through the route's ContentReader (chunked or not) into `body`,
// exactly `limit` bytes at most. On failure the error to send (413 over the limit, 429 over the
// budget, 400 for a broken transfer) and the connection is marked to close after the answer,
// since the rest of the body is still on the wire.
std::optional<api::ApiError> read_body(const httplib::ContentReader& reader, std::size_t limit,
                                       Body& body);

} // namespace textond::http
