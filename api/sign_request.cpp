#include "api/sign_request.h"

#include "api/json_body.h"

#include <nlohmann/json.hpp>

namespace textond::api {

namespace {
ApiError invalid(const std::string& why) {
    return {"invalid_body",
            "expected {\"urls\": [\"/v1/...\", ...], \"expires_in\": SECONDS}: " + why};
}
} // namespace

std::optional<ApiError> parse_sign(std::string_view body, SignRequest& out) {
    // The document is built only once its size is known to be that of such a request.
    if (auto e = check_json_bounds(body, 2, kMaxSignUrls + 16))
        return invalid(e->code == "payload_too_large"
                           ? "at most " + std::to_string(kMaxSignUrls) + " urls a request"
                           : e->message);
    const auto j = nlohmann::json::parse(body, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return invalid("the body is not a JSON object");
    for (const auto& [k, v] : j.items())
        if (k != "urls" && k != "expires_in")
            return invalid("unknown field '" + k.substr(0, 40) + "'");
    const auto urls = j.find("urls");
    if (urls == j.end() || !urls->is_array() || urls->empty())
        return invalid("urls must be a non-empty array");
    if (urls->size() > kMaxSignUrls)
        return invalid("at most " + std::to_string(kMaxSignUrls) + " urls a request");
    for (const auto& u : *urls) {
        if (!u.is_string()) return invalid("every url is a string");
        const auto& s = u.get_ref<const std::string&>();
        if (s.size() > kMaxSignUrlBytes)
            return invalid("a url of more than " + std::to_string(kMaxSignUrlBytes) + " bytes");
        out.urls.push_back(s);
    }
    if (const auto e = j.find("expires_in"); e != j.end()) {
        if (!e->is_number_integer() || e->get<std::int64_t>() < 1 ||
            e->get<std::int64_t>() > kMaxSignSeconds)
            return invalid("expires_in is whole seconds in 1.." + std::to_string(kMaxSignSeconds));
        out.expires_in = e->get<std::int64_t>();
    }
    return std::nullopt;
}

} // namespace textond::api
