#pragma once
// Texton analyses on a bounded pool, one job per texton id (single flight): an upload of an
// exemplar that is already being analysed joins that job instead of starting another. When every
// worker is busy and the queue is full, submit() refuses and the caller answers 429.
#include "api/texton_meta.h"
#include "core/result.h"
#include "core/texton_analysis.h"

#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace textond::app {

struct AnalysisOutcome {
    api::TextonMeta meta;
    bool created = false; // false: the texton was already stored when the job ran
};

class AnalysisJob {
public:
    enum class State { queued, running, done, failed };
    explicit AnalysisJob(std::string id) : m_id(std::move(id)) {}

    const std::string& id() const { return m_id; }
    State state() const;
    std::pair<int, int> progress() const; // projections done, total
    // Blocks until the job has finished.
    const Result<AnalysisOutcome>& wait() const;
    // Waits at most `timeout`; the result once finished, else null.
    const Result<AnalysisOutcome>* wait_for(std::chrono::milliseconds timeout) const;

private:
    friend class AnalysisPool;
    const std::string m_id;
    mutable std::mutex m_mutex;
    mutable std::condition_variable m_cv;
    State m_state = State::queued;
    int m_waiters = 0;   // clients waiting on the connection for the answer
    bool m_kept = false; // a client that polls its status will come back for it
    int m_done = 0, m_total = 0;
    std::optional<Result<AnalysisOutcome>> m_result;
};

const char* to_string(AnalysisJob::State s);

class AnalysisPool {
public:
    using Work = std::function<Result<AnalysisOutcome>(const core::ProgressFn&)>;

    AnalysisPool(int workers, int queue_capacity);
    ~AnalysisPool();
    AnalysisPool(const AnalysisPool&) = delete;
    AnalysisPool& operator=(const AnalysisPool&) = delete;

    struct Submitted {
        std::shared_ptr<AnalysisJob> job; // null: queue full
        bool joined = false;              // an identical upload was already in flight
    };
    Submitted submit(const std::string& id, Work work);
    // A client waits for `job` (on its connection, or by polling its status when `polls`).
    void attach(const std::shared_ptr<AnalysisJob>& job, bool polls);
    // A waiting client left. When no client waits for a job that has not started, it is dropped
    // from the queue (failed: nobody would read its answer, and it would hold a worker for
    // nothing); a job already running finishes and is stored.
    void leave(const std::shared_ptr<AnalysisJob>& job);
    // A job in flight or recently finished (status queries), or null.
    std::shared_ptr<AnalysisJob> find(const std::string& id) const;
    // Every job in flight and every one recently finished (the job board publishes them).
    std::vector<std::shared_ptr<AnalysisJob>> jobs() const;

    int queued() const;
    int running() const;
    int dropped() const; // queued jobs dropped because every client left
    int workers() const { return static_cast<int>(m_threads.size()); }
    // Finishes the running jobs, fails the queued ones, joins the workers.
    void shutdown();

private:
    void worker_loop();

    const std::size_t m_capacity;
    mutable std::mutex m_mutex;
    std::condition_variable m_cv;
    std::deque<std::pair<std::shared_ptr<AnalysisJob>, Work>> m_queue;
    std::map<std::string, std::shared_ptr<AnalysisJob>> m_in_flight;
    std::deque<std::shared_ptr<AnalysisJob>> m_recent; // finished, for status queries
    int m_running = 0;
    int m_dropped = 0;
    bool m_stopping = false;
    std::vector<std::thread> m_threads;
};

} // namespace textond::app
