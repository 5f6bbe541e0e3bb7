#include "server/store/periodic_sweep.h"

#include <algorithm>

namespace textond::store {

PeriodicSweep::PeriodicSweep(std::chrono::milliseconds every, std::function<void()> sweep)
    : m_every(std::max<std::chrono::milliseconds>(every, std::chrono::seconds(1))),
      m_sweep(std::move(sweep)), m_thread([this] { loop(); }) {}

PeriodicSweep::~PeriodicSweep() {
    {
        std::lock_guard lock(m_mutex);
        m_stopping = true;
    }
    m_cv.notify_all();
    m_thread.join();
}

bool PeriodicSweep::stopping() const {
    std::lock_guard lock(m_mutex);
    return m_stopping;
}

void PeriodicSweep::loop() {
    std::unique_lock lock(m_mutex);
    while (!m_cv.wait_for(lock, m_every, [this] { return m_stopping; })) {
        lock.unlock();
        m_sweep();
        lock.lock();
    }
}

} // namespace textond::store
