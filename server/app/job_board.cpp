#include "server/app/job_board.h"

namespace textond::app {

namespace {
bool ended(AnalysisJob::State s) {
    return s == AnalysisJob::State::done || s == AnalysisJob::State::failed;
}
} // namespace

JobBoard::JobBoard(AnalysisPool& pool, store::RedisStore* shared, Describe describe)
    : m_pool(pool), m_shared(shared), m_describe(std::move(describe)) {
    if (m_shared)
        m_sweep =
            std::make_unique<store::PeriodicSweep>(std::chrono::seconds(1), [this] { sweep(); });
}

void JobBoard::publish(const AnalysisJob& job) {
    if (!m_shared) return;
    const bool end = ended(job.state());
    if (end) {
        const std::lock_guard<std::mutex> lock(m_mutex);
        if (m_finished.size() > 4096) m_finished.clear(); // the pool remembers 256
        if (!m_finished.insert(job.id()).second) return;
    }
    // Best effort: a store that is down loses a status answer, never an upload.
    (void)m_shared->put_job(job.id(), m_describe(job).dump(), end ? kFinishedTtl : kRunningTtl);
}

std::optional<nlohmann::json> JobBoard::find(const std::string& id) {
    if (!m_shared) return std::nullopt;
    auto got = m_shared->get_job(id);
    if (!got || !got.value()) return std::nullopt;
    auto body = nlohmann::json::parse(*got.value(), nullptr, false);
    if (!body.is_object() || body.value("id", "") != id || !body.contains("state"))
        return std::nullopt; // not what a replica publishes
    return body;
}

void JobBoard::sweep() {
    for (const auto& job : m_pool.jobs()) publish(*job);
}

} // namespace textond::app
