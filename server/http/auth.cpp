#include "server/http/auth.h"

#include "server/http/responses.h"

#include <openssl/crypto.h>

#include <cctype>
#include <string_view>

namespace textond::http {

bool holds_api_key(const std::string& api_key, const httplib::Request& req) {
    if (api_key.empty()) return false;
    // The scheme's name is case-insensitive and one or more spaces follow it (RFC 9110 11.4);
    // the key is compared in constant time.
    const std::string got = req.get_header_value("Authorization");
    constexpr std::string_view kScheme = "bearer";
    if (got.size() <= kScheme.size() || got[kScheme.size()] != ' ') return false;
    for (std::size_t i = 0; i < kScheme.size(); ++i)
        if (std::tolower(static_cast<unsigned char>(got[i])) != kScheme[i]) return false;
    const std::size_t key = got.find_first_not_of(' ', kScheme.size());
    if (key == std::string::npos || got.size() - key != api_key.size()) return false;
    return CRYPTO_memcmp(got.data() + key, api_key.data(), api_key.size()) == 0;
}

bool authorised(const std::string& api_key, const httplib::Request& req, httplib::Response& res) {
    if (api_key.empty() || holds_api_key(api_key, req)) return true;
    res.set_header("WWW-Authenticate", "Bearer realm=\"textond\"");
    send_error(res, {"unauthorized",
                     "this server needs an API key for writes: Authorization: Bearer <key>"});
    return false;
}

} // namespace textond::http
