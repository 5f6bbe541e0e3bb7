#pragma once
#include "server/http/imports.h"
// Rate limits on cold work (--render-rate a minute, --render-burst): a token bucket per client,
// taken only by renders (a cache miss), never by cache hits or 304s, which cost next to nothing. A
// client is its API key when it sends one (Authorization: Bearer, or X-API-Key), else its
// address. An empty bucket gets 429 rate_limited with Retry-After. No HTTP here: the image
// routes ask it before a render.
#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>
#include <unordered_map>

namespace textond::http {

class RateLimiter {
public:
    using Clock = std::chrono::steady_clock;
    // `per_second` tokens a second, up to `burst`; per_second 0: no limit.
    RateLimiter(double per_second, double burst, std::size_t max_clients = 100'000);

    bool enabled() const { return m_rate > 0; }
    // Takes a token for `client`; when none is left, 0 and the seconds until one is in
    // `retry_after_s`.
    bool take(const std::string& client, double& retry_after_s);
    // The same at a time of the caller's (tests).
    bool take(const std::string& client, double& retry_after_s, Clock::time_point now);
    std::size_t clients() const;

private:
    struct Bucket {
        double tokens = 0;
        Clock::time_point at;
    };
    bool take_locked(const std::string& client, double& retry_after_s, Clock::time_point now);
    double m_rate, m_burst;
    std::size_t m_max_clients;
    mutable std::mutex m_mutex;
    std::unordered_map<std::string, Bucket> m_buckets;
};

} // namespace textond::http
