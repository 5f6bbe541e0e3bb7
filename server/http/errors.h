#pragma once
#include "server/http/imports.h"
// The one table from an error code (api::ApiError::code, the `code` of every JSON error body) to
// its HTTP status. api/ and core/ name no status; routes name a code and send_error() looks the
// status up here. api/openapi.yaml lists the same codes (tests/server/errors_test.cpp).
#include <string_view>
#include <utility>
#include <vector>

namespace textond::http {

struct ErrorStatus {
    std::string_view code;
    int status;
};

// Every code, in the order api/openapi.yaml lists them.
const std::vector<ErrorStatus>& error_table();

// The status of `code`; 500 (and an error in the log) for a code missing from the table.
// "http_error" has none of its own: cpp-httplib's status is kept for it.
int http_status(std::string_view code);

} // namespace textond::http
