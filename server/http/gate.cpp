#include "server/http/gate.h"

#include "server/http/connection.h"
#include "server/http/responses.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <thread>

namespace textond::http {

namespace {
int cores() {
    const unsigned n = std::thread::hardware_concurrency();
    return n == 0 ? 1 : static_cast<int>(n);
}
} // namespace

Gate::Gate(const ServeConfig& config, Metrics& metrics)
    : m_config(config), m_metrics(metrics),
      m_render_slots(config.render_slots > 0 ? config.render_slots : cores(),
                     static_cast<std::size_t>(config.render_queue)),
      m_decode_slots(cores(), static_cast<std::size_t>(config.render_queue)),
      m_bodies(config.body_budget_bytes), m_decoded(config.body_budget_bytes) {}

bool Gate::within_budget(httplib::Response& res, double work_s, double cpu_share, const char* ask) {
    work_s *= cpu_share + (1.0 - cpu_share) * m_work_factor;
    if (!(work_s <= m_config.max_request_cpu_s)) {
        char buf[256];
        std::snprintf(buf, sizeof buf,
                      "this request would take about %.3g CPU seconds, over the server's budget "
                      "of %.3g (--max-request-cpu-s): ask for %s",
                      work_s, m_config.max_request_cpu_s,
                      ask ? ask : "fewer pixels, points or a lower mni");
        m_metrics.not_admitted("too_large");
        send_error(res, {"work_too_large", buf});
        return false;
    }
    return true;
}

void Gate::refuse(httplib::Response& res, WorkSlots::Admit why, const char* busy) {
    if (why == WorkSlots::Admit::gone) {
        m_metrics.not_admitted("gone");
        return send_error(res, {"client_gone", "the client left before the work started"});
    }
    m_metrics.not_admitted("busy");
    res.set_header("Retry-After", "1");
    send_error(res, {"overloaded", busy});
}

std::optional<SlotGuard> Gate::admit(httplib::Response& res, double work_s, double cpu_share) {
    if (!within_budget(res, work_s, cpu_share)) return std::nullopt;
    ConnectionStream* conn = current_connection();
    const auto gone = [conn] { return conn && conn->client_gone(); };
    const auto why =
        m_render_slots.acquire(std::chrono::milliseconds(m_config.queue_timeout_ms), gone);
    if (why == WorkSlots::Admit::granted) return SlotGuard(&m_render_slots);
    refuse(res, why, "every render slot is busy and the wait is too long; retry shortly");
    return std::nullopt;
}

render::Cancel Gate::work_cancel() const {
    ConnectionStream* conn = current_connection();
    return render::Cancel(std::chrono::steady_clock::now() +
                              std::chrono::seconds(m_config.render_deadline_s),
                          [conn] { return conn && conn->client_gone(); });
}

void Gate::send_work_error(httplib::Response& res, const Error& e, const render::Cancel& cancel,
                           const std::string& code) {
    if (e.code == ErrorCode::cancelled) {
        const bool deadline = cancel.deadline_passed();
        m_metrics.abandoned(deadline);
        if (!deadline) {
            if (ConnectionStream* conn = current_connection()) conn->close_after_response();
            return send_error(res, {"client_gone", "the client left during the work"});
        }
        res.set_header("Retry-After", "1");
    }
    send_error(res, to_api_error(e, code));
}

std::optional<SlotGuard> Gate::admit_decode(httplib::Response& res) {
    const auto why = m_decode_slots.acquire(std::chrono::milliseconds(m_config.queue_timeout_ms));
    if (why == WorkSlots::Admit::granted) return SlotGuard(&m_decode_slots);
    refuse(res, why, "every decoder is busy; retry shortly");
    return std::nullopt;
}

std::shared_ptr<BudgetLease> Gate::lease_transfer(httplib::Response& res, std::size_t bytes) {
    return lease(m_bodies, res, bytes, "too many large responses in flight; retry shortly");
}

std::shared_ptr<BudgetLease> Gate::lease_decode(httplib::Response& res, std::size_t bytes) {
    return lease(m_decoded, res, bytes, "too many large images being decoded; retry shortly");
}

std::shared_ptr<BudgetLease> Gate::lease(BodyBudget& budget, httplib::Response& res,
                                         std::size_t bytes, const char* busy) {
    ConnectionStream* conn = current_connection();
    const auto end =
        std::chrono::steady_clock::now() + std::chrono::milliseconds(m_config.queue_timeout_ms);
    // One lease alone always fits, beside a quarter of the budget held by other requests:
    // clamped to the whole budget, a lease waited for every small body in flight to end.
    bytes = std::min(bytes, budget.cap() / 4 * 3);
    while (!budget.reserve(bytes)) {
        if (conn && conn->client_gone()) {
            m_metrics.not_admitted("gone");
            send_error(res, {"client_gone", "the client left before the work started"});
            return nullptr;
        }
        if (std::chrono::steady_clock::now() >= end) {
            m_metrics.not_admitted("busy");
            res.set_header("Retry-After", "1");
            send_error(res, {"overloaded", busy});
            return nullptr;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return std::make_shared<BudgetLease>(budget, bytes);
}

bool Gate::read_request_body(const httplib::ContentReader& reader, httplib::Response& res,
                             Body& body, std::size_t limit) {
    if (limit == 0 || limit > m_config.max_upload_bytes) limit = m_config.max_upload_bytes;
    if (auto e = read_body(reader, limit, body)) {
        if (e->code == "overloaded") res.set_header("Retry-After", "1");
        send_error(res, *e);
        return false;
    }
    return true;
}

void Gate::pool_full(httplib::Response& res, const AnalysisPool& pool) {
    const int wait_s = 1 + pool.queued() / std::max(1, pool.workers());
    res.set_header("Retry-After", std::to_string(wait_s));
    send_error(res,
               {"overloaded", "every analysis worker is busy and the queue is full; retry after " +
                                  std::to_string(wait_s) + " s"});
}

} // namespace textond::http
