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

void JobBoard::publish(const std::shared_ptr<AnalysisJob>& job) {
    if (!m_shared) return;
    const bool end = ended(job->state());
    if (end) {
        const std::lock_guard<std::mutex> lock(m_mutex);
        if (m_finished[job->id()].lock() == job) return;
    }
    // Best effort: a store that is down loses a status answer, never an upload. An end is
    // remembered as published only once stored, so the next sweep tries a lost one again.
    auto put =
        m_shared->put_job(job->id(), m_describe(*job).dump(), end ? kFinishedTtl : kRunningTtl);
    if (end && put && put.value()) {
        const std::lock_guard<std::mutex> lock(m_mutex);
        m_finished[job->id()] = job;
    }
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
    // An id's newest job only: one in flight, else the last to end (the pool lists those in
    // flight first, then the ended oldest first). An older end would overwrite a newer answer.
    // Each job's state is read once: one that ends during the loop keeps its place.
    std::map<std::string, std::pair<std::shared_ptr<AnalysisJob>, bool>> newest; // job, ended
    for (const auto& job : m_pool.jobs()) {
        auto& [kept, kept_ended] = newest[job->id()];
        if (!kept || kept_ended) {
            kept = job;
            kept_ended = ended(job->state());
        }
    }
    for (const auto& [id, job] : newest) publish(job.first);
    const std::lock_guard<std::mutex> lock(m_mutex);
    for (auto it = m_finished.begin(); it != m_finished.end();)
        it = it->second.expired() ? m_finished.erase(it) : std::next(it);
}

} // namespace textond::app
