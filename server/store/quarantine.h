#pragma once
// Files refused at load (damaged, or failing today's rules) are moved aside, never rendered and
// never deleted: <dir>/quarantine/<id><suffix>.<milliseconds>.
#include <cstddef>
#include <initializer_list>
#include <string>
#include <vector>

namespace textond::store {

// Moves <dir>/<id><suffix> for each suffix; removes a file that cannot be moved. Returns the
// quarantine directory.
std::string quarantine_files(const std::string& dir, const std::string& id,
                             std::initializer_list<const char*> suffixes);

// What a quarantine directory holds, for /readyz and /metrics: the first kListed names in name
// order and how many there are. Files are moved there and never deleted, so it only grows: what
// a request reads of it stays this small whatever it holds.
class QuarantineList {
public:
    static constexpr std::size_t kListed = 100;
    // Counted once: a name already listed is not counted again.
    void add(const std::string& name);
    const std::vector<std::string>& names() const { return m_names; }
    std::size_t count() const { return m_count; }

private:
    std::vector<std::string> m_names; // sorted, at most kListed
    std::size_t m_count = 0;
};

// What <dir>/quarantine/ holds, so that a restart still reports what earlier runs moved aside:
// its regular files' names (dot-files aside), or (`ids`) the ids that begin them, each once.
QuarantineList quarantined_on_disk(const std::string& dir, bool ids);

} // namespace textond::store
