#pragma once
// A replica's data directory is a read-through cache of the shared store: a copy it cannot write
// there (its disk full) is no fault of the object, and another replica can serve it. So such a
// read answers 503 (the edge then asks the next replica: proxy_next_upstream), not 507, and says
// so without naming this server's paths.
#include "core/result.h"

#include <string>

namespace textond::store {

inline Error read_through_error(const std::string& what, Error e) {
    if (e.code != ErrorCode::no_space) return e;
    return Error{ErrorCode::unavailable,
                 what + " is in the shared store, but this replica's disk is full and cannot "
                        "hold its copy; another replica can serve it (retry)"};
}

} // namespace textond::store
