#include "server/http/auth.h"

#include "server/http/responses.h"

#include <openssl/crypto.h>

namespace textond::http {

bool holds_api_key(const std::string& api_key, const httplib::Request& req) {
    if (api_key.empty()) return false;
    const std::string got = req.get_header_value("Authorization"), want = "Bearer " + api_key;
    return got.size() == want.size() && CRYPTO_memcmp(got.data(), want.data(), want.size()) == 0;
}

bool authorised(const std::string& api_key, const httplib::Request& req, httplib::Response& res) {
    if (api_key.empty() || holds_api_key(api_key, req)) return true;
    res.set_header("WWW-Authenticate", "Bearer realm=\"textond\"");
    send_error(res, {"unauthorized",
                     "this server needs an API key for writes: Authorization: Bearer <key>"});
    return false;
}

} // namespace textond::http
