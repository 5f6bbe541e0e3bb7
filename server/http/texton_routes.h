#pragma once
// POST/GET/DELETE /v1/textons...: uploads (TextonService's ingest), metadata, analysis status,
// the texton's files and engine kit, deletion and listing.
#include "api/texton_meta.h"
#include "server/app/analysis_pool.h"
#include "server/app/job_board.h"
#include "server/app/texton_service.h"
#include "server/http/config.h"
#include "server/http/gate.h"
#include "server/http/imports.h"
#include "server/store/image_cache.h"
#include "server/store/texton_store.h"

#include <httplib.h>
#include <nlohmann/json.hpp>

#include <atomic>

namespace textond::http {

class TextonRoutes {
public:
    // `stopping`: uploads get 503 once the service is shutting down.
    TextonRoutes(const ServeConfig& config, TextonStore& store, TextonService& textons,
                 AnalysisPool& pool, ImageCache& cache, Gate& gate,
                 const std::atomic<bool>& stopping);
    // A job's status answer (GET /v1/textons/{id}/status while it is in the pool).
    static nlohmann::json job_status(const AnalysisJob& job);

    using Req = const httplib::Request&;
    using Res = httplib::Response&;
    void upload(Req req, Res res, const httplib::ContentReader& reader);
    void list(Req req, Res res);
    void get(Req req, Res res);
    void status(Req req, Res res);
    void file(Req req, Res res);
    void remove(Req req, Res res);
    // Anything else under /v1/textons/: a bad id is a 400 (never a path), a good one a 404.
    static void fallback(Req req, Res res);

private:
    std::optional<std::shared_ptr<BudgetLease>>
    lease_decodes(Res res, const std::vector<std::string_view>& images);
    void send_refused(Res res, const TextonService::Refused& r);
    void send_ingested(Req req, Res res, const TextonService::Ingested& in);

    const ServeConfig& m_config;
    TextonStore& m_store;
    TextonService& m_textons;
    AnalysisPool& m_pool;
    JobBoard m_board; // the jobs of every replica, with a shared store
    ImageCache& m_cache;
    Gate& m_gate;
    const std::atomic<bool>& m_stopping;
};

} // namespace textond::http
