#pragma once
// The service's admission control (what work costs: server/app/work_cost.h; slots:
// server/app/slots.h; bodies: request_body.h): whether a request's work fits the CPU budget, a
// render or decoder slot to do it in, a share of the byte budget for a large answer, a body read
// within the upload limit, and what stops admitted work. Each method that refuses has already sent
// its answer (413, 408 client_gone, 429 with Retry-After).
#include "core/result.h"
#include "render/cancel.h"
#include "server/app/analysis_pool.h"
#include "server/app/metrics.h"
#include "server/http/config.h"
#include "server/http/imports.h"
#include "server/http/request_body.h"

#include <httplib.h>

#include <memory>
#include <optional>
#include <string>

namespace textond::http {

class Gate {
public:
    // `render_slots` 0: one per core; decoders are one per core.
    Gate(const ServeConfig& config, Metrics& metrics);

    // A render slot for work estimated at `work_s` CPU seconds: 413 over --max-request-cpu-s,
    // 429 when no slot frees within --queue-timeout-ms, 408 when the client left meanwhile.
    // `cpu_share`: the part of the work that runs on the CPU whatever the backend (normal maps,
    // the kit); the rest is multiplied by the backend's work factor.
    std::optional<SlotGuard> admit(httplib::Response& res, double work_s, double cpu_share = 0);
    // `ask`: what the 413's message asks for instead (default: fewer pixels, points or MNI).
    bool within_budget(httplib::Response& res, double work_s, double cpu_share = 0,
                       const char* ask = nullptr); // 413 sent when not
    // Estimates are the CPU path's (server/app/work_cost.h); a backend that does the same
    // work slower (llvmpipe) multiplies them, so admission counts what will really run.
    void set_work_factor(double factor) { m_work_factor = factor > 0 ? factor : 1.0; }
    double work_factor() const { return m_work_factor; }
    // A decoder slot (masks), waiting like admit().
    std::optional<SlotGuard> admit_decode(httplib::Response& res);
    // The answer for work not admitted: 408 when the client left, else 429 with `busy`.
    void refuse(httplib::Response& res, WorkSlots::Admit why, const char* busy);
    // What stops admitted work: its client leaving, or --render-deadline-s from now.
    render::Cancel work_cancel() const;
    // The answer for work that failed: an abandoned one is counted (and gets 503 when its
    // deadline passed; a client that left reads nothing), any other error as to_api_error.
    void send_work_error(httplib::Response& res, const Error& e, const render::Cancel& cancel,
                         const std::string& code = {});
    // `bytes` of the body budget for a large response, waiting like admit() (429 sent).
    std::shared_ptr<BudgetLease> lease_transfer(httplib::Response& res, std::size_t bytes);
    // `bytes` of the decode budget (the decoded pixels of uploads and splat weights), waiting
    // like admit(). Apart from the body budget: twelve splat creations whose bodies held most of
    // it each waited for the rest, and nothing moved until their queue timeouts.
    std::shared_ptr<BudgetLease> lease_decode(httplib::Response& res, std::size_t bytes);
    // The body of a POST route, read with the upload limit or a smaller `limit` of the route's
    // own (sends the error on failure).
    bool read_request_body(const httplib::ContentReader& reader, httplib::Response& res, Body& body,
                           std::size_t limit = 0);

    // 429 with a Retry-After from the analysis pool's queue (uploads and mixes).
    void pool_full(httplib::Response& res, const AnalysisPool& pool);

    WorkSlots& render_slots() { return m_render_slots; }
    WorkSlots& decode_slots() { return m_decode_slots; }
    BodyBudget& bodies() { return m_bodies; }

private:
    const ServeConfig& m_config;
    Metrics& m_metrics;
    WorkSlots m_render_slots;
    // Decoding an upload takes up to 16 bytes a pixel (268 MB at the 16.8 MP default): bounded
    // so that many simultaneous large uploads cannot exhaust memory.
    WorkSlots m_decode_slots;
    BodyBudget m_bodies;  // request bodies held in memory, all requests together
    BodyBudget m_decoded; // decoded pixels of uploads and splat weights, all requests together
    std::shared_ptr<BudgetLease> lease(BodyBudget& budget, httplib::Response& res,
                                       std::size_t bytes, const char* busy);
    double m_work_factor = 1.0;
};

} // namespace textond::http
