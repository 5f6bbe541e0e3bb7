#pragma once
// Analyses in flight, seen from every replica. An upload that asks to poll (202) may have its
// status URL answered by another replica behind the edge (the POST is spread by request, the
// status by the id), which knew nothing of the job and said 404 for the whole analysis. With a
// shared store, each replica publishes its jobs' status answers there (RedisStore::put_job): at
// once for a 202, then every second while they run (each expires 10 s after its last
// publication), and once more when they end (kept 5 minutes, as long as a finished job is
// remembered for status queries at most). Without one, nothing is published or found.
#include "server/app/analysis_pool.h"
#include "server/store/periodic_sweep.h"
#include "server/store/redis_store.h"

#include <nlohmann/json.hpp>

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace textond::app {

class JobBoard {
public:
    // `describe`: the status answer of a job, as the replica that runs it gives it.
    using Describe = std::function<nlohmann::json(const AnalysisJob&)>;
    JobBoard(AnalysisPool& pool, store::RedisStore* shared, Describe describe);
    JobBoard(const JobBoard&) = delete;
    JobBoard& operator=(const JobBoard&) = delete;

    // Publishes `job`'s status answer; an ended job once (an id analysed again, after a delete,
    // is a new job and publishes its own end).
    void publish(const std::shared_ptr<AnalysisJob>& job);
    // The status answer another replica published for `id`; nullopt when none (or no store).
    std::optional<nlohmann::json> find(const std::string& id);

    static constexpr std::chrono::seconds kRunningTtl{10};
    static constexpr std::chrono::seconds kFinishedTtl{300};

private:
    void sweep();
    AnalysisPool& m_pool;
    store::RedisStore* const m_shared;
    const Describe m_describe;
    std::mutex m_mutex;
    // Per id, the job whose end was published: not again. Gone once the pool forgets the job.
    std::map<std::string, std::weak_ptr<const AnalysisJob>> m_finished;
    std::unique_ptr<store::PeriodicSweep> m_sweep; // last: started once the rest is made
};

} // namespace textond::app
