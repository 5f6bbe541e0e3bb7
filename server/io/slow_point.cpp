#include "server/io/slow_point.h"

#include <chrono>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <thread>

namespace textond::io {

namespace {
std::map<std::string, double, std::less<>> armed_points() {
    std::map<std::string, double, std::less<>> out;
    const char* v = std::getenv("TEXTOND_SLOW_POINT");
    std::stringstream list(v ? v : "");
    std::string item;
    while (std::getline(list, item, ',')) {
        const auto eq = item.find('=');
        if (eq == std::string::npos) continue;
        char* end = nullptr;
        const double factor = std::strtod(item.c_str() + eq + 1, &end);
        if (end && *end == '\0' && factor > 0) out[item.substr(0, eq)] = factor;
    }
    return out;
}
} // namespace

bool slow_point(std::string_view name, double estimate_s, const std::function<bool()>& stop) {
    static const auto armed = armed_points();
    const auto it = armed.find(name);
    if (it == armed.end()) return true;
    using Clock = std::chrono::steady_clock;
    const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                        std::chrono::duration<double>(estimate_s * it->second));
    while (Clock::now() < end) {
        if (stop && stop()) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return !(stop && stop());
}

} // namespace textond::io
