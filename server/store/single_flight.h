#pragma once
// One run of a piece of work a key at a time: callers that arrive while it runs wait for its
// outcome instead of doing it again (eight tile requests once read eight copies of a 100 MB value
// from the shared store). Used by the fetches of TextonStore and SharedObjects.
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace textond::store {

template <class T> class SingleFlight {
public:
    // `work` runs on the first caller's thread; the others get a copy of what it returned.
    template <class Work> T run(const std::string& key, Work work) {
        std::shared_ptr<Flight> flight;
        bool leader = false;
        {
            std::lock_guard lock(m_mutex);
            auto& slot = m_flights[key];
            if (!slot) {
                slot = std::make_shared<Flight>();
                leader = true;
            }
            flight = slot;
        }
        if (!leader) {
            std::unique_lock lock(m_mutex);
            m_done.wait(lock, [&] { return flight->result.has_value(); });
            return *flight->result;
        }
        T result = work();
        {
            std::lock_guard lock(m_mutex);
            flight->result = result;
            m_flights.erase(key);
        }
        m_done.notify_all();
        return result;
    }

private:
    struct Flight {
        std::optional<T> result;
    };
    std::mutex m_mutex;
    std::condition_variable m_done;
    std::map<std::string, std::shared_ptr<Flight>> m_flights;
};

} // namespace textond::store
