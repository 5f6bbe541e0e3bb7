#include "server/store/quarantine.h"

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

} // namespace textond::store
