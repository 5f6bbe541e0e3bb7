#pragma once
// Files refused at load (damaged, or failing today's rules) are moved aside, never rendered and
// never deleted: <dir>/quarantine/<id><suffix>.<milliseconds>.
#include <initializer_list>
#include <string>
#include <vector>

namespace textond::store {

// Moves <dir>/<id><suffix> for each suffix; removes a file that cannot be moved. Returns the
// quarantine directory.
std::string quarantine_files(const std::string& dir, const std::string& id,
                             std::initializer_list<const char*> suffixes);

// What <dir>/quarantine/ holds, by name, so that a restart still reports what earlier runs
// moved aside: every file's name, or (`ids`) the ids that begin them, each once.
std::vector<std::string> quarantined_on_disk(const std::string& dir, bool ids);

} // namespace textond::store
