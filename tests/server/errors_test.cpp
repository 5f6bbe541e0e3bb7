// The error table of server/http/errors.cpp against api/openapi.yaml: one list of codes, each
// with one status, and the fallbacks for what is not in it.
#include "api/openapi_spec.h"
#include "server/http/errors.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace textond::http {
namespace {

// The codes of the Error schema's description: "stable, machine-readable: a, b, c (...), d."
// (the list ends at the first full stop outside parentheses).
std::set<std::string> spec_codes() {
    const std::string spec = api::kOpenApiYaml;
    const std::string start = "stable, machine-readable:";
    auto from = spec.find(start);
    if (from == std::string::npos) return {};
    from += start.size();
    const auto to = spec.find("message:", from);
    std::set<std::string> codes;
    std::string word;
    int depth = 0; // words inside parentheses are prose, not codes
    for (char c : spec.substr(from, to - from)) {
        if (c == '(') ++depth;
        if (c == ')') --depth;
        if (depth == 0 && ((c >= 'a' && c <= 'z') || c == '_')) {
            word += c;
            continue;
        }
        if (!word.empty() && depth == 0) codes.insert(word);
        word.clear();
        if (c == '.' && depth == 0) break;
    }
    return codes;
}

TEST(Errors, TheTableAndTheSpecListTheSameCodes) {
    const std::set<std::string> spec = spec_codes();
    ASSERT_GT(spec.size(), 30u);
    std::set<std::string> table;
    for (const ErrorStatus& e : error_table()) {
        EXPECT_TRUE(table.insert(std::string(e.code)).second) << e.code << " twice";
        EXPECT_GE(e.status, 400) << e.code;
        EXPECT_LE(e.status, 599) << e.code;
    }
    table.insert("http_error"); // keeps cpp-httplib's status: no row of its own
    for (const std::string& c : spec) EXPECT_TRUE(table.count(c)) << c << " is not in the table";
    for (const std::string& c : table) EXPECT_TRUE(spec.count(c)) << c << " is not in the spec";
}

TEST(Errors, StatusesOfTheCodesClientsBranchOn) {
    EXPECT_EQ(http_status("invalid_parameter"), 400);
    EXPECT_EQ(http_status("not_found"), 404);
    EXPECT_EQ(http_status("client_gone"), 408);
    EXPECT_EQ(http_status("payload_too_large"), 413);
    EXPECT_EQ(http_status("unsupported_media_type"), 415);
    EXPECT_EQ(http_status("exemplar_too_small"), 422);
    EXPECT_EQ(http_status("overloaded"), 429);
    EXPECT_EQ(http_status("header_too_large"), 431);
    EXPECT_EQ(http_status("store_unavailable"), 503);
    EXPECT_EQ(http_status("insufficient_storage"), 507);
    EXPECT_EQ(http_status("no_such_code"), 500);
}

} // namespace
} // namespace textond::http
