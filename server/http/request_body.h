#pragma once
// Request bodies held in memory: read with exact limits for every transfer encoding, inside a
// process-wide budget of body bytes, so that memory grows with the slots and not with the
// clients. What work may cost is server/app/work_cost.h, when it may start server/app/slots.h.
#include "api/requests.h"
#include "server/app/slots.h"
#include "server/http/imports.h"

#include <httplib.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace textond::http {

// Bytes of request bodies held in memory by all requests at once.
class BodyBudget {
public:
    explicit BodyBudget(std::size_t bytes) : m_cap(bytes) {}
    bool reserve(std::size_t n);
    void release(std::size_t n) { m_used -= n; }
    std::size_t used() const { return m_used; }
    std::size_t cap() const { return m_cap; }

private:
    const std::size_t m_cap;
    std::atomic<std::size_t> m_used{0};
};

// Bytes of the budget held by one response until it has been written.
class BudgetLease {
public:
    BudgetLease(BodyBudget& budget, std::size_t n) : m_budget(budget), m_n(n) {}
    ~BudgetLease() { m_budget.release(m_n); }
    BudgetLease(const BudgetLease&) = delete;
    BudgetLease& operator=(const BudgetLease&) = delete;

private:
    BodyBudget& m_budget;
    std::size_t m_n;
};

// A request's body in memory, its bytes counted in the budget until it is dropped.
class Body {
public:
    explicit Body(BodyBudget& budget) : m_budget(budget) {}
    ~Body() { m_budget.release(m_reserved); }
    Body(const Body&) = delete;
    Body& operator=(const Body&) = delete;
    std::string bytes;
    // Appends, reserving budget in 1 MiB steps; false when over `limit` or the budget.
    bool append(const char* data, std::size_t n, std::size_t limit);
    // Counts n more bytes held elsewhere (multipart parts) against `limit` and the budget.
    bool count(std::size_t n, std::size_t limit);
    bool over_limit() const { return m_over_limit; }
    bool over_budget() const { return m_over_budget; }

private:
    BodyBudget& m_budget;
    std::size_t m_reserved = 0, m_counted = 0;
    bool m_over_limit = false, m_over_budget = false;
};

// Reads a non-multipart body through the route's ContentReader (chunked or not) into `body`,
// exactly `limit` bytes at most. On failure the error to send (413 over the limit, 429 over the
// budget, 400 for a broken transfer) and the connection is marked to close after the answer,
// since the rest of the body is still on the wire.
std::optional<api::ApiError> read_body(const httplib::ContentReader& reader, std::size_t limit,
                                       Body& body);

inline constexpr std::size_t kMaxParts = 64;

// A multipart form's parts, every byte counted against `limit` and the server's budget for
// bodies in memory; at most kMaxParts parts (400 saying so past them). `status` is the response's
// status so far (cpp-httplib sets 413 when its own limit stopped the read). Errors as read_body's.
std::optional<api::ApiError> read_parts(const httplib::ContentReader& reader, std::size_t limit,
                                        int status, Body& counted,
                                        std::vector<httplib::MultipartFormData>& parts);

} // namespace textond::http
