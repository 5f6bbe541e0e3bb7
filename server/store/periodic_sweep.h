#pragma once
// A thread that runs a sweep once an interval until it is destroyed (TextonStore's and
// SharedObjects' write-backs to the shared store). The interval is at least a second:
// --store-recheck-s 0 rechecks on every request, and a sweep on it had spun a core.
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace textond::store {

class PeriodicSweep {
public:
    // `sweep` runs on the thread; it may return early when stopping() says so.
    PeriodicSweep(std::chrono::milliseconds every, std::function<void()> sweep);
    ~PeriodicSweep(); // stops and joins: what sweep uses must outlive this
    PeriodicSweep(const PeriodicSweep&) = delete;
    PeriodicSweep& operator=(const PeriodicSweep&) = delete;
    bool stopping() const;

private:
    void loop();
    const std::chrono::milliseconds m_every;
    const std::function<void()> m_sweep;
    mutable std::mutex m_mutex;
    std::condition_variable m_cv;
    bool m_stopping = false;
    std::thread m_thread; // last: started once the rest is made
};

} // namespace textond::store
