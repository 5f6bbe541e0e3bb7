#include "server/http/admission.h"

#include "core/working_window.h"

#include "api/safe_text.h"
#include "server/http/connection.h"

#include <algorithm>
#include <cctype>

namespace textond::http {

int taps_of_order(int order) {
    return order == 3 ? 16 : order == 1 ? 4 : 1;
}

double noise_work_s(std::int64_t pixels, double mni, int order) {
    return static_cast<double>(pixels) * mni * taps_of_order(order) * 1.5e-9;
}

double surface_work_s(std::size_t points, double mni, int order) {
    return static_cast<double>(points) * mni * taps_of_order(order) * 55e-9;
}

double mesh_work_s(std::uint64_t raster_tests, std::int64_t pixels, double mni, int order) {
    return static_cast<double>(raster_tests) * 10e-9 +
           surface_work_s(static_cast<std::size_t>(pixels), mni, order);
}

double analysis_work_s(int width, int height, int channels, int iterations) {
    constexpr double kAnalysisNs = 13; // fitted by tests/bench/analysis_cost.py
    const double window = static_cast<double>(std::min(width, core::kWorkingSide)) *
                          std::min(height, core::kWorkingSide) * channels;
    const double whole = static_cast<double>(width) * height * channels;
    return window * (iterations + 8) * kAnalysisNs * 1e-9 + whole * 10e-9;
}

RenderSlots::Admit RenderSlots::acquire(std::chrono::milliseconds max_wait,
                                        const std::function<bool()>& gone) {
    std::unique_lock lock(m_mutex);
    if (m_free > 0 && m_waiters.empty()) {
        --m_free;
        return Admit::granted;
    }
    if (m_waiters.size() >= m_max_waiters) return Admit::busy;
    Waiter me;
    m_waiters.push_back(&me);
    const auto end = std::chrono::steady_clock::now() + max_wait;
    Admit outcome = Admit::granted;
    while (!me.granted) {
        const auto now = std::chrono::steady_clock::now();
        if (now >= end) {
            outcome = Admit::busy;
            break;
        }
        me.cv.wait_until(lock, std::min(end, now + std::chrono::milliseconds(100)));
        if (me.granted) break;
        if (gone) {
            lock.unlock();
            const bool left = gone();
            lock.lock();
            if (left && !me.granted) {
                outcome = Admit::gone;
                break;
            }
        }
    }
    if (me.granted) return Admit::granted; // granted while deciding to leave: keep it
    m_waiters.erase(std::find(m_waiters.begin(), m_waiters.end(), &me));
    return outcome;
}

void RenderSlots::release() {
    std::lock_guard lock(m_mutex);
    if (m_waiters.empty()) {
        ++m_free;
        return;
    }
    Waiter* next = m_waiters.front();
    m_waiters.pop_front();
    next->granted = true; // the slot passes straight to the next waiter
    next->cv.notify_one();
}

void RenderSlots::add(int n) {
    for (int i = 0; i < n; ++i) release();
}

std::size_t RenderSlots::waiting() const {
    std::lock_guard lock(m_mutex);
    return m_waiters.size();
}

bool BodyBudget::reserve(std::size_t n) {
    std::size_t used = m_used.load();
    do {
        if (used + n > m_cap) return false;
    } while (!m_used.compare_exchange_weak(used, used + n));
    return true;
}

bool Body::count(std::size_t n, std::size_t limit) {
    if (m_counted + n > limit) {
        m_over_limit = true;
        return false;
    }
    if (m_counted + n > m_reserved) {
        const std::size_t step = std::size_t{1} << 20;
        const std::size_t want = std::min(limit, (m_counted + n + step - 1) / step * step);
        if (!m_budget.reserve(want - m_reserved)) {
            m_over_budget = true;
            return false;
        }
        m_reserved = want;
    }
    m_counted += n;
    return true;
}

bool Body::append(const char* data, std::size_t n, std::size_t limit) {
    if (!count(n, limit)) return false;
    bytes.append(data, n);
    return true;
}

std::optional<api::ApiError> read_body(const httplib::ContentReader& reader, std::size_t limit,
                                       Body& body) {
    const bool ok =
        reader([&](const char* data, std::size_t n) { return body.append(data, n, limit); });
    if (ok) return std::nullopt;
    if (ConnectionStream* c = current_connection()) c->close_after_response();
    if (body.over_limit())
        return api::ApiError{"payload_too_large", "request body is over the limit of " +
                                                      std::to_string(limit) + " bytes"};
    if (body.over_budget())
        return api::ApiError{"overloaded",
                             "the server holds too many request bodies now; retry shortly"};
    return api::ApiError{"bad_request", "could not read the request body"};
}

} // namespace textond::http
