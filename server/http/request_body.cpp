#include "server/http/request_body.h"

#include "api/safe_text.h"
#include "server/http/connection.h"

#include <algorithm>
#include <cctype>

namespace textond::http {

bool BodyBudget::reserve(std::size_t n) {
    std::size_t used = m_used.load();
    do {
        if (used + n > m_cap) return false;
    } while (!m_used.compare_exchange_weak(used, used + n));
    return true;
}

bool Body::count(std::size_t n, std::size_t limit) {
    if (m_counted + n > limit) {
        m_over_limit = true;
        return false;
    }
    if (m_counted + n > m_reserved) {
        const std::size_t step = std::size_t{1} << 20;
        const std::size_t want = std::min(limit, (m_counted + n + step - 1) / step * step);
        if (!m_budget.reserve(want - m_reserved)) {
            m_over_budget = true;
            return false;
        }
        m_reserved = want;
    }
    m_counted += n;
    return true;
}

bool Body::append(const char* data, std::size_t n, std::size_t limit) {
    if (!count(n, limit)) return false;
    bytes.append(data, n);
    return true;
}

std::optional<api::ApiError> read_body(const httplib::ContentReader& reader, std::size_t limit,
                                       Body& body) {
    const bool ok =
        reader([&](const char* data, std::size_t n) { return body.append(data, n, limit); });
    if (ok) return std::nullopt;
    if (ConnectionStream* c = current_connection()) c->close_after_response();
    if (body.over_limit())
        return api::ApiError{"payload_too_large", "request body is over the limit of " +
                                                      std::to_string(limit) + " bytes"};
    if (body.over_budget())
        return api::ApiError{"overloaded",
                             "the server holds too many request bodies now; retry shortly"};
    return api::ApiError{"bad_request", "could not read the request body"};
}

std::optional<api::ApiError> read_parts(const httplib::ContentReader& reader, std::size_t limit,
                                        int status, Body& counted,
                                        std::vector<httplib::MultipartFormData>& parts) {
    const bool ok = reader(
        [&](const httplib::MultipartFormData& part) {
            parts.push_back(part);
            return parts.size() <= kMaxParts && counted.count(part.name.size(), limit);
        },
        [&](const char* data, std::size_t n) {
            if (!counted.count(n, limit)) return false;
            parts.back().content.append(data, n);
            return true;
        });
    if (ok) return std::nullopt;
    // The rest of the body is unread: what follows on the connection is not a request.
    if (ConnectionStream* c = current_connection()) c->close_after_response();
    if (counted.over_budget())
        return api::ApiError{"overloaded",
                             "the server holds too many request bodies now; retry shortly"};
    if (counted.over_limit() || status == 413)
        return api::ApiError{"payload_too_large", "request body is over the upload limit of " +
                                                      std::to_string(limit) + " bytes"};
    if (parts.size() > kMaxParts)
        return api::ApiError{"bad_request", "the form has more than " + std::to_string(kMaxParts) +
                                                " parts; no route takes that many"};
    return api::ApiError{"bad_request", "could not read the request body"};
}

} // namespace textond::http
