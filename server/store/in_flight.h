#pragma once
// Ids that an operation is in the middle of, counted (two at once of one id are two), each for
// the scope of a Mark: what another path must leave alone meanwhile. Used for creations in
// flight, which a write-back to the shared store must not beat (TextonStore, SharedObjects).
#include <map>
#include <mutex>
#include <string>
#include <utility>

namespace textond::store {

class InFlightIds {
public:
    class Mark {
    public:
        Mark(InFlightIds& ids, std::string id) : m_ids(ids), m_id(std::move(id)) {
            std::lock_guard lock(m_ids.m_mutex);
            ++m_ids.m_count[m_id];
        }
        ~Mark() {
            std::lock_guard lock(m_ids.m_mutex);
            if (--m_ids.m_count[m_id] == 0) m_ids.m_count.erase(m_id);
        }
        Mark(const Mark&) = delete;
        Mark& operator=(const Mark&) = delete;

    private:
        InFlightIds& m_ids;
        const std::string m_id;
    };

    bool contains(const std::string& id) const {
        std::lock_guard lock(m_mutex);
        return m_count.count(id) != 0;
    }

    // Runs `f` unless `id` is marked, with no Mark taken meanwhile: a creation marks its id before
    // it writes a file, so what `f` removes cannot be that creation's. Whether `f` ran.
    template <class F> bool unless_marked(const std::string& id, F&& f) {
        std::lock_guard lock(m_mutex);
        if (m_count.count(id) != 0) return false;
        f();
        return true;
    }

private:
    mutable std::mutex m_mutex;
    std::map<std::string, int> m_count;
};

} // namespace textond::store
