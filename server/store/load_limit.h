#pragma once
// At most a few loads of one kind of stored object at once. Loading a splat or a mix that no
// request holds decodes its weight images or mask and prepares it (about 200 MB at the largest):
// sixteen requests for sixteen splats on a fresh replica took 3.3 GB before this bound. A load
// that finds no room within `wait` is refused (unavailable, 503) rather than queued for ever;
// loads are served in the order they asked.
#include "core/result.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>

namespace textond::store {

class LoadLimit {
public:
    explicit LoadLimit(int at_once) : m_free(at_once) {}

    // Runs `load` once a place is free, in the order the loads asked (a client cycling through
    // many ids cannot keep another's load waiting past its turn); unavailable when its turn does
    // not come within `wait`.
    template <class T, class Load>
    Result<T> run(const std::string& what, std::chrono::milliseconds wait, Load load) {
        {
            std::unique_lock lock(m_mutex);
            const std::uint64_t me = m_next++;
            m_queue.push_back(me);
            if (!m_turn.wait_for(lock, wait, [&] { return m_free > 0 && m_queue.front() == me; })) {
                m_queue.erase(std::find(m_queue.begin(), m_queue.end(), me));
                m_turn.notify_all(); // the one behind may be first now
                return make_error(ErrorCode::unavailable,
                                  "too many " + what + " being loaded at once; retry shortly");
            }
            m_queue.pop_front();
            --m_free;
        }
        m_turn.notify_all(); // the next in line may take another free place
        struct Release {
            LoadLimit& l;
            ~Release() {
                {
                    std::lock_guard lock(l.m_mutex);
                    ++l.m_free;
                }
                l.m_turn.notify_all();
            }
        } release{*this};
        return load();
    }

private:
    std::mutex m_mutex;
    std::condition_variable m_turn;
    int m_free;
    std::uint64_t m_next = 0;
    std::deque<std::uint64_t> m_queue; // waiting loads, oldest first
};

} // namespace textond::store
