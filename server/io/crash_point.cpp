#include "server/io/crash_point.h"

#include <cstdlib>
#include <string>
#include <unistd.h>

namespace textond::io {

void crash_point(std::string_view name) {
    static const std::string armed = [] {
        const char* v = std::getenv("TEXTOND_CRASH_POINT");
        return std::string(v ? v : "");
    }();
    if (!armed.empty() && name == armed) ::_exit(86);
}

} // namespace textond::io
