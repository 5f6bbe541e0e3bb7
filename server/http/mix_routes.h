#pragma once
// Texture mixes (texton-noise section 7): POST /v1/mixes from two textons (MixService's
// workflow) and GET /v1/mixes/{id}; their images are ImageRoutes'.
#include "server/app/analysis_pool.h"
#include "server/app/mix_service.h"
#include "server/http/config.h"
#include "server/http/gate.h"
#include "server/http/imports.h"
#include "server/store/image_cache.h"
#include "server/store/mix_store.h"

#include <httplib.h>

namespace textond::http {

class MixRoutes {
public:
    MixRoutes(const ServeConfig& config, MixService& service, MixStore& mixes, AnalysisPool& pool,
              ImageCache& cache, Gate& gate);

    using Req = const httplib::Request&;
    using Res = httplib::Response&;
    void create(Req req, Res res, const httplib::ContentReader& reader);
    void get(Req req, Res res);
    // DELETE: here, in the shared store (every replica) and in this replica's image cache.
    void remove(Req req, Res res);
    // Anything else under /v1/mixes/: a bad id is a 400 (never a path), a good one a 404.
    static void fallback(Req req, Res res);

private:
    // The mask of a masked mix (the body), decoded under a decoder slot with its decoded size
    // reserved (`lease`, to hold until the answer); false when the error was sent.
    bool read_mask(Res res, const std::string& bytes, api::MixRequest& m,
                   std::shared_ptr<BudgetLease>& lease);

    const ServeConfig& m_config;
    MixService& m_service;
    MixStore& m_mixes;
    AnalysisPool& m_pool;
    ImageCache& m_cache;
    Gate& m_gate;
};

} // namespace textond::http
