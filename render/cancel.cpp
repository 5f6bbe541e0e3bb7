#include "render/cancel.h"

#include <string>

namespace textond::render {

Error abandoned(const Cancel* c, const char* what) {
    return make_error(ErrorCode::cancelled, c && c->deadline_passed()
                                                ? std::string(what) + " passed its deadline"
                                                : "the client left during " + std::string(what));
}

bool Cancel::stop() const {
    if (m_stopped.load(std::memory_order_relaxed)) return true;
    const auto now = Clock::now();
    if (now >= m_deadline) {
        m_deadline_passed.store(true, std::memory_order_relaxed);
        m_stopped.store(true, std::memory_order_relaxed);
        return true;
    }
    if (!m_gone) return false;
    auto next = m_next_poll.load(std::memory_order_relaxed);
    const auto t = now.time_since_epoch().count();
    if (t < next) return false;
    const auto after = (now + m_poll_every).time_since_epoch().count();
    if (!m_next_poll.compare_exchange_strong(next, after, std::memory_order_relaxed)) return false;
    if (m_gone()) m_stopped.store(true, std::memory_order_relaxed);
    return m_stopped.load(std::memory_order_relaxed);
}

} // namespace textond::render
