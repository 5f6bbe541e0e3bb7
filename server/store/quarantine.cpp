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

std::vector<std::string> quarantined_on_disk(const std::string& dir, bool ids) {
    namespace fs = std::filesystem;
    std::vector<std::string> out;
    std::error_code ec;
    for (fs::directory_iterator it(fs::path(dir) / "quarantine", ec), end; !ec && it != end;
         it.increment(ec)) {
        std::string name = it->path().filename().string();
        if (ids) name = name.substr(0, name.find('.'));
        out.push_back(std::move(name));
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

} // namespace textond::store
