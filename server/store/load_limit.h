#pragma once
// At most a few loads of one kind of stored object at once. Loading a splat or a mix that no
// request holds decodes its weight images or mask and prepares it (about 200 MB at the largest):
// sixteen requests for sixteen splats on a fresh replica took 3.3 GB before this bound. A load
// that finds no room within `wait` is refused (unavailable, 503) rather than queued for ever.
#include "core/result.h"

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>

namespace textond::store {

class LoadLimit {
public:
    explicit LoadLimit(int at_once) : m_free(at_once) {}

    // Runs `load` once a place is free; unavailable when none is within `wait`.
    template <class T, class Load>
    Result<T> run(const std::string& what, std::chrono::milliseconds wait, Load load) {
        {
            std::unique_lock lock(m_mutex);
            if (!m_freed.wait_for(lock, wait, [&] { return m_free > 0; }))
                return make_error(ErrorCode::unavailable,
                                  "too many " + what + " being loaded at once; retry shortly");
            --m_free;
        }
        struct Release {
            LoadLimit& l;
            ~Release() {
                {
                    std::lock_guard lock(l.m_mutex);
                    ++l.m_free;
                }
                l.m_freed.notify_one();
            }
        } release{*this};
        return load();
    }

private:
    std::mutex m_mutex;
    std::condition_variable m_freed;
    int m_free;
};

} // namespace textond::store
