#include "server/app/analysis_pool.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <exception>

namespace textond::app {

namespace {
constexpr std::size_t kRecentJobs = 256;
}

const char* to_string(AnalysisJob::State s) {
    switch (s) {
    case AnalysisJob::State::queued:
        return "queued";
    case AnalysisJob::State::running:
        return "running";
    case AnalysisJob::State::done:
        return "done";
    case AnalysisJob::State::failed:
        return "failed";
    }
    return "unknown";
}

AnalysisJob::State AnalysisJob::state() const {
    std::lock_guard lock(m_mutex);
    return m_state;
}

std::pair<int, int> AnalysisJob::progress() const {
    std::lock_guard lock(m_mutex);
    return {m_done, m_total};
}

const Result<AnalysisOutcome>& AnalysisJob::wait() const {
    std::unique_lock lock(m_mutex);
    m_cv.wait(lock, [&] { return m_result.has_value(); });
    return *m_result;
}

const Result<AnalysisOutcome>* AnalysisJob::wait_for(std::chrono::milliseconds timeout) const {
    std::unique_lock lock(m_mutex);
    if (!m_cv.wait_for(lock, timeout, [&] { return m_result.has_value(); })) return nullptr;
    return &*m_result;
}

void AnalysisPool::attach(const std::shared_ptr<AnalysisJob>& job, bool polls) {
    std::lock_guard lock(job->m_mutex);
    if (polls)
        job->m_kept = true;
    else
        ++job->m_waiters;
}

void AnalysisPool::leave(const std::shared_ptr<AnalysisJob>& job) {
    {
        std::lock_guard lock(m_mutex);
        std::lock_guard job_lock(job->m_mutex);
        if (--job->m_waiters > 0 || job->m_kept || job->m_state != AnalysisJob::State::queued)
            return;
        const auto it = std::find_if(m_queue.begin(), m_queue.end(),
                                     [&](const auto& queued) { return queued.first == job; });
        if (it == m_queue.end()) return;
        m_queue.erase(it);
        m_in_flight.erase(job->id());
        job->m_state = AnalysisJob::State::failed;
        job->m_result = make_error(ErrorCode::unavailable,
                                   "the analysis was dropped before it started: its client left");
        ++m_dropped;
    }
    job->m_cv.notify_all();
    spdlog::info("analysis {} dropped from the queue: its client left", job->id());
}

AnalysisPool::AnalysisPool(int workers, int queue_capacity)
    : m_capacity(static_cast<std::size_t>(queue_capacity < 0 ? 0 : queue_capacity)) {
    for (int i = 0; i < (workers < 1 ? 1 : workers); ++i)
        m_threads.emplace_back([this] { worker_loop(); });
}

AnalysisPool::~AnalysisPool() {
    shutdown();
}

AnalysisPool::Submitted AnalysisPool::submit(const std::string& id, Work work) {
    std::lock_guard lock(m_mutex);
    if (auto it = m_in_flight.find(id); it != m_in_flight.end()) return {it->second, true};
    // A free worker takes the job at once; otherwise it waits in a queue of bounded length.
    const std::size_t idle = m_threads.size() - static_cast<std::size_t>(m_running);
    if (m_stopping || m_queue.size() >= m_capacity + idle) return {nullptr, false};
    auto job = std::make_shared<AnalysisJob>(id);
    m_in_flight[id] = job;
    m_queue.emplace_back(job, std::move(work));
    m_cv.notify_one();
    return {job, false};
}

std::shared_ptr<AnalysisJob> AnalysisPool::find(const std::string& id) const {
    std::lock_guard lock(m_mutex);
    if (auto it = m_in_flight.find(id); it != m_in_flight.end()) return it->second;
    for (auto it = m_recent.rbegin(); it != m_recent.rend(); ++it)
        if ((*it)->id() == id) return *it;
    return nullptr;
}

std::vector<std::shared_ptr<AnalysisJob>> AnalysisPool::jobs() const {
    std::lock_guard lock(m_mutex);
    std::vector<std::shared_ptr<AnalysisJob>> out;
    out.reserve(m_in_flight.size() + m_recent.size());
    for (const auto& [id, job] : m_in_flight) out.push_back(job);
    out.insert(out.end(), m_recent.begin(), m_recent.end());
    return out;
}

int AnalysisPool::queued() const {
    std::lock_guard lock(m_mutex);
    return static_cast<int>(m_queue.size());
}

int AnalysisPool::dropped() const {
    std::lock_guard lock(m_mutex);
    return m_dropped;
}

int AnalysisPool::running() const {
    std::lock_guard lock(m_mutex);
    return m_running;
}

void AnalysisPool::worker_loop() {
    for (;;) {
        std::shared_ptr<AnalysisJob> job;
        Work work;
        {
            std::unique_lock lock(m_mutex);
            m_cv.wait(lock, [&] { return m_stopping || !m_queue.empty(); });
            if (m_queue.empty()) return; // stopping
            job = std::move(m_queue.front().first);
            work = std::move(m_queue.front().second);
            m_queue.pop_front();
            ++m_running;
        }
        {
            std::lock_guard lock(job->m_mutex);
            job->m_state = AnalysisJob::State::running;
        }
        Result<AnalysisOutcome> result = make_error(ErrorCode::internal, "analysis did not run");
        try {
            result = work([&job](int done, int total) {
                std::lock_guard lock(job->m_mutex);
                job->m_done = done;
                job->m_total = total;
            });
        } catch (const std::exception& e) {
            spdlog::error("analysis {} threw: {}", job->id(), e.what());
            result = make_error(ErrorCode::internal, std::string("analysis failed: ") + e.what());
        }
        // Leave the in-flight map only once the texton is stored (the work stores it), so a
        // later identical upload either joins this job or finds the texton in the store.
        {
            std::lock_guard lock(m_mutex);
            m_in_flight.erase(job->id());
            m_recent.push_back(job);
            if (m_recent.size() > kRecentJobs) m_recent.pop_front();
            --m_running;
        }
        {
            std::lock_guard lock(job->m_mutex);
            job->m_state = result ? AnalysisJob::State::done : AnalysisJob::State::failed;
            job->m_result = std::move(result);
        }
        job->m_cv.notify_all();
    }
}

void AnalysisPool::shutdown() {
    std::deque<std::pair<std::shared_ptr<AnalysisJob>, Work>> dropped;
    {
        std::lock_guard lock(m_mutex);
        if (m_stopping && m_threads.empty()) return;
        m_stopping = true;
        dropped.swap(m_queue);
        for (auto& [job, work] : dropped) m_in_flight.erase(job->id());
    }
    m_cv.notify_all();
    for (auto& [job, work] : dropped) {
        {
            std::lock_guard lock(job->m_mutex);
            job->m_state = AnalysisJob::State::failed;
            job->m_result = Result<AnalysisOutcome>(
                make_error(ErrorCode::internal, "the service is shutting down"));
        }
        job->m_cv.notify_all();
    }
    for (auto& t : m_threads)
        if (t.joinable()) t.join();
    m_threads.clear();
}

} // namespace textond::app
