#include "server/store/quarantine.h"

#include <algorithm>
#include <chrono>
#include <filesystem>

namespace textond::store {

std::string quarantine_files(const std::string& dir, const std::string& id,
                             std::initializer_list<const char*> suffixes) {
    namespace fs = std::filesystem;
    const fs::path to = fs::path(dir) / "quarantine";
    std::error_code ec;
    fs::create_directories(to, ec);
    const std::string stamp = std::to_string(std::chrono::system_clock::now().time_since_epoch() /
                                             std::chrono::milliseconds(1));
    for (const char* suffix : suffixes) {
        const fs::path from = fs::path(dir) / (id + suffix);
        if (!fs::exists(from, ec)) continue;
        std::string name = id;
        name.append(suffix).append(".").append(stamp);
        fs::rename(from, to / name, ec);
        if (ec) fs::remove(from, ec); // never leave it where it could be rendered
    }
    return to.string();
}

void QuarantineList::add(const std::string& name) {
    const auto at = std::lower_bound(m_names.begin(), m_names.end(), name);
    if (at != m_names.end() && *at == name) return;
    ++m_count;
    if (at == m_names.end() && m_names.size() >= kListed) return;
    m_names.insert(at, name);
    if (m_names.size() > kListed) m_names.pop_back();
}

QuarantineList quarantined_on_disk(const std::string& dir, bool ids) {
    namespace fs = std::filesystem;
    std::vector<std::string> names;
    std::error_code ec;
    for (fs::directory_iterator it(fs::path(dir) / "quarantine", ec), end; !ec && it != end;
         it.increment(ec)) {
        std::error_code type_ec;
        if (!it->is_regular_file(type_ec)) continue;
        std::string name = it->path().filename().string();
        if (name.empty() || name.front() == '.') continue;
        if (ids) name = name.substr(0, name.find('.'));
        names.push_back(std::move(name));
    }
    // Sorted and unique before counting: a mix's two files are one quarantined mix.
    std::sort(names.begin(), names.end());
    names.erase(std::unique(names.begin(), names.end()), names.end());
    QuarantineList out;
    for (const std::string& n : names) out.add(n);
    return out;
}

} // namespace textond::store
