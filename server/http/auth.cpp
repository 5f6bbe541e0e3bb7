#include "server/http/auth.h"

#include "server/http/responses.h"

namespace textond::http {

namespace {
bool constant_time_equal(const std::string& a, const std::string& b) {
    unsigned char diff = a.size() == b.size() ? 0 : 1;
    const std::string& ref = a.size() == b.size() ? b : a;
    for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ ref[i]);
    return diff == 0;
}
} // namespace

bool authorised(const std::string& api_key, const httplib::Request& req, httplib::Response& res) {
    if (api_key.empty()) return true;
    const std::string h = req.get_header_value("Authorization");
    const std::string prefix = "Bearer ";
    if (h.size() > prefix.size() && h.compare(0, prefix.size(), prefix) == 0 &&
        constant_time_equal(h.substr(prefix.size()), api_key))
        return true;
    res.set_header("WWW-Authenticate", "Bearer realm=\"textond\"");
    send_error(res, {"unauthorized",
                     "this server needs an API key for writes: Authorization: Bearer <key>"});
    return false;
}

} // namespace textond::http
