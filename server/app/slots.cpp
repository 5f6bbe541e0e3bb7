#include "server/app/slots.h"

#include <algorithm>

namespace textond::app {

WorkSlots::Admit WorkSlots::acquire(std::chrono::milliseconds max_wait,
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

void WorkSlots::release() {
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

void WorkSlots::add(int n) {
    for (int i = 0; i < n; ++i) release();
}

int WorkSlots::free() const {
    std::lock_guard lock(m_mutex);
    return m_free;
}

std::size_t WorkSlots::waiting() const {
    std::lock_guard lock(m_mutex);
    return m_waiters.size();
}

} // namespace textond::app
