#include "server/http/rate_limiter.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <vector>

namespace textond::http {

RateLimiter::RateLimiter(double per_second, double burst, std::size_t max_clients)
    : m_rate(per_second), m_burst(std::max(1.0, burst)), m_max_clients(max_clients) {}

bool RateLimiter::take(const std::string& client, double& retry_after_s) {
    if (!enabled()) {
        retry_after_s = 0;
        return true;
    }
    std::lock_guard lock(m_mutex); // the clock under the lock: a bucket's time never goes back
    return take_locked(client, retry_after_s, Clock::now());
}

bool RateLimiter::take(const std::string& client, double& retry_after_s, Clock::time_point now) {
    retry_after_s = 0;
    if (!enabled()) return true;
    std::lock_guard lock(m_mutex);
    return take_locked(client, retry_after_s, now);
}

bool RateLimiter::take_locked(const std::string& client, double& retry_after_s,
                              Clock::time_point now) {
    retry_after_s = 0;
    auto it = m_buckets.find(client);
    if (it == m_buckets.end()) {
        // Bounded memory: past the limit, forget the clients whose buckets have refilled (they
        // would start full anyway); if none has, the oldest half.
        if (m_buckets.size() >= m_max_clients) {
            const double full_after = m_burst / m_rate;
            for (auto b = m_buckets.begin(); b != m_buckets.end();)
                b = std::chrono::duration<double>(now - b->second.at).count() >= full_after
                        ? m_buckets.erase(b)
                        : std::next(b);
            if (m_buckets.size() >= m_max_clients) {
                std::vector<Clock::time_point> ages;
                ages.reserve(m_buckets.size());
                for (const auto& [k, b] : m_buckets) ages.push_back(b.at);
                auto mid = ages.begin() + static_cast<std::ptrdiff_t>(ages.size() / 2);
                std::nth_element(ages.begin(), mid, ages.end());
                for (auto b = m_buckets.begin(); b != m_buckets.end();)
                    b = b->second.at <= *mid ? m_buckets.erase(b) : std::next(b);
            }
        }
        it = m_buckets.emplace(client, Bucket{m_burst, now}).first;
    }
    Bucket& b = it->second;
    b.tokens =
        std::min(m_burst, b.tokens + m_rate * std::chrono::duration<double>(now - b.at).count());
    b.at = now;
    if (b.tokens >= 1.0) {
        b.tokens -= 1.0;
        return true;
    }
    retry_after_s = (1.0 - b.tokens) / m_rate;
    return false;
}

std::size_t RateLimiter::clients() const {
    std::lock_guard lock(m_mutex);
    return m_buckets.size();
}

} // namespace textond::http
