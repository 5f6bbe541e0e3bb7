#pragma once
// Files refused at load (damaged, or failing today's rules) are moved aside, never rendered and
// never deleted: <dir>/quarantine/<id><suffix>.<milliseconds>.
#include <initializer_list>
#include <string>

namespace textond::store {

// Moves <dir>/<id><suffix> for each suffix; removes a file that cannot be moved. Returns the
// quarantine directory.
std::string quarantine_files(const std::string& dir, const std::string& id,
                             std::initializer_list<const char*> suffixes);

} // namespace textond::store
