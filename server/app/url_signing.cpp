#include "server/app/url_signing.h"

#include <nlohmann/json.hpp>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>

#include <algorithm>
#include <cstdio>
#include <regex>
#include <vector>

namespace textond::app {

namespace {

api::ApiError forbidden(const char* code, std::string message) {
    return {code, std::move(message)};
}

bool preset_name_ok(const std::string& name) {
    return !name.empty() && name.size() <= 64 && std::all_of(name.begin(), name.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.';
    });
}

int hex_digit(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

// Percent-decoding of one query component ('+' is a space), as cpp-httplib decodes the request.
std::string decode_component(std::string_view s) {
    std::string out;
    for (std::size_t i = 0; i < s.size(); ++i) {
        if (s[i] == '+') {
            out += ' ';
        } else if (s[i] == '%' && i + 2 < s.size() + 0 && hex_digit(s[i + 1]) >= 0 &&
                   hex_digit(s[i + 2]) >= 0) {
            out += static_cast<char>(hex_digit(s[i + 1]) * 16 + hex_digit(s[i + 2]));
            i += 2;
        } else {
            out += s[i];
        }
    }
    return out;
}

} // namespace

Result<Presets> parse_presets(std::string_view text) {
    const auto doc = nlohmann::json::parse(text, nullptr, false);
    if (doc.is_discarded() || !doc.is_object() || doc.empty())
        return make_error(ErrorCode::invalid_argument,
                          "presets must be a JSON object of named objects of query fields");
    Presets out;
    for (const auto& [name, fields] : doc.items()) {
        if (!preset_name_ok(name))
            return make_error(ErrorCode::invalid_argument,
                              "preset name '" + name.substr(0, 40) +
                                  "' must be 1-64 letters, digits, '-', '_' or '.'");
        if (!fields.is_object())
            return make_error(ErrorCode::invalid_argument,
                              "preset '" + name + "' is not an object");
        Preset p;
        for (const auto& [field, value] : fields.items()) {
            std::string v;
            if (value.is_string())
                v = value.get<std::string>();
            else if (value.is_number_integer())
                v = value.dump(); // as written: seeds are 64-bit
            else if (value.is_number())
                v = api::query_text(value.get<double>()); // 30.0 is mni=30 in a URL
            std::string what = "preset '" + name + "'";
            if (!value.is_string() && !value.is_number())
                return make_error(
                    ErrorCode::invalid_argument,
                    what.append(": field '").append(field).append("' must be a string or number"));
            if (field == "preset" || field == "sig" || field == "exp")
                return make_error(ErrorCode::invalid_argument,
                                  what.append(" cannot set '").append(field).append("'"));
            if (field == "format" && !api::parse_image_format(v))
                return make_error(ErrorCode::invalid_argument,
                                  what.append(": format must be png, png16, exr, webp or avif, "
                                              "not '")
                                      .append(v.substr(0, 20))
                                      .append("'"));
            if (field == "format")
                p.format = v;
            else
                p.fields.emplace(field, v);
        }
        if (p.format.empty())
            return make_error(ErrorCode::invalid_argument,
                              "preset '" + name +
                                  "' must name its format (png, png16, exr, webp "
                                  "or avif): a preset pins every variant");
        // The fields as a tile would read them: an unknown or bad one is refused now, not in
        // every request.
        api::TileRequest probe;
        if (auto e =
                api::parse_tile(std::string(64, '0'), "0", "0", "0", p.format, p.fields, probe))
            return make_error(ErrorCode::invalid_argument, "preset '" + name + "': " + e->message);
        out.emplace(name, std::move(p));
    }
    return out;
}

std::string signed_path(std::string_view path) {
    // .../tiles/Z/X/Y[@2x][.ext] and .../map/Z/X/Y[@2x][.ext]: the layer.
    static const std::regex tile(R"(^(.*/(?:tiles|map)/)[^/]+/[^/]+/[^/.@]+(@2x)?(\.[a-z0-9]+)?$)");
    std::cmatch m;
    std::string p(path);
    if (std::regex_match(p.c_str(), m, tile))
        return m[1].str() + "{z}/{x}/{y}" + m[2].str() + m[3].str();
    return p;
}

// '%', '&' and '=' of a key or value escaped, so that no field can pass for two.
std::string escaped(const std::string& s) {
    std::string out;
    for (char c : s) {
        if (c == '%')
            out += "%25";
        else if (c == '&')
            out += "%26";
        else if (c == '=')
            out += "%3D";
        else
            out += c;
    }
    return out;
}

std::string canonical_request(std::string_view path, const api::Query& query) {
    std::vector<std::pair<std::string, std::string>> fields;
    for (const auto& [k, v] : query)
        if (k != "sig") fields.emplace_back(escaped(k), escaped(v));
    std::sort(fields.begin(), fields.end());
    std::string out = signed_path(path) + "?";
    for (std::size_t i = 0; i < fields.size(); ++i)
        out.append(i ? "&" : "").append(fields[i].first).append("=").append(fields[i].second);
    return out;
}

std::string url_signature(std::string_view key, std::string_view canonical) {
    unsigned char mac[EVP_MAX_MD_SIZE];
    unsigned int n = 0;
    if (!HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()),
              reinterpret_cast<const unsigned char*>(canonical.data()), canonical.size(), mac,
              &n) ||
        n != 32)
        return ""; // never equal to a signature: check_signature refuses an empty one
    std::string hex;
    char buf[3];
    for (unsigned int i = 0; i < n; ++i) {
        std::snprintf(buf, sizeof buf, "%02x", mac[i]);
        hex += buf;
    }
    return hex;
}

std::optional<api::ApiError> check_signature(std::string_view key, std::string_view path,
                                             const api::Query& query, std::int64_t now) {
    const auto sig = query.find("sig");
    if (sig == query.end())
        return forbidden(
            "signature_missing",
            "this server signs its image URLs: add sig (textond sign URL; api/README.md "
            "\"Signed URLs and presets\")");
    if (query.count("sig") > 1 || query.count("exp") > 1)
        return forbidden("signature_invalid", "sig and exp may be given once");
    const std::string want = url_signature(key, canonical_request(path, query));
    // Constant time: a timing oracle would give the signature away byte by byte.
    if (want.empty() || sig->second.size() != want.size() ||
        CRYPTO_memcmp(sig->second.data(), want.data(), want.size()) != 0)
        return forbidden("signature_invalid",
                         "the signature does not match this path and query (or this key)");
    if (const auto exp = query.find("exp"); exp != query.end()) {
        const auto t = api::parse_i64(exp->second);
        if (!t) return forbidden("signature_invalid", "exp must be Unix seconds");
        if (now > *t) return forbidden("signature_expired", "this signed URL has expired");
    }
    return std::nullopt;
}

Result<std::string> sign_url(std::string_view key, std::string_view url, std::int64_t expires) {
    if (key.size() < kMinSigningKey)
        return make_error(ErrorCode::invalid_argument, "the signing key must have at least " +
                                                           std::to_string(kMinSigningKey) +
                                                           " characters");
    // Split scheme://host, path and query; drop any sig, keep (or set) exp. A fragment is the
    // client's own (never sent to a server): not signed, put back after the signature.
    std::string u(url);
    std::string fragment;
    if (const auto hash = u.find('#'); hash != std::string::npos) {
        fragment = u.substr(hash);
        u.resize(hash);
    }
    std::size_t path_at = 0;
    if (const auto scheme = u.find("://"); scheme != std::string::npos) {
        path_at = u.find('/', scheme + 3);
        if (path_at == std::string::npos)
            return make_error(ErrorCode::invalid_argument, "the URL has no path");
    }
    if (path_at >= u.size() || u[path_at] != '/')
        return make_error(ErrorCode::invalid_argument, "the URL's path must start with /");
    const std::size_t q = u.find('?', path_at);
    const std::string base = u.substr(0, q == std::string::npos ? u.size() : q);
    const std::string path = base.substr(path_at);
    std::string raw_query = q == std::string::npos ? "" : u.substr(q + 1);
    api::Query fields;
    std::vector<std::string> kept; // the query as written, sig and exp dropped
    std::size_t at = 0;
    while (at <= raw_query.size() && !raw_query.empty()) {
        const std::size_t amp = std::min(raw_query.find('&', at), raw_query.size());
        const std::string item = raw_query.substr(at, amp - at);
        at = amp + 1;
        if (item.empty()) continue;
        const std::size_t eq = item.find('=');
        const std::string k = decode_component(item.substr(0, eq));
        const std::string v = eq == std::string::npos ? "" : decode_component(item.substr(eq + 1));
        if (k == "sig" || (k == "exp" && expires > 0)) continue;
        fields.emplace(k, v);
        kept.push_back(item);
    }
    if (expires > 0) {
        fields.emplace("exp", std::to_string(expires));
        kept.push_back("exp=" + std::to_string(expires));
    }
    std::string out = base + "?";
    for (const auto& item : kept) out += item + "&";
    return out + "sig=" + url_signature(key, canonical_request(path, fields)) + fragment;
}

std::optional<api::ApiError> apply_preset(const Presets& presets, const api::Query& query,
                                          std::string_view format, api::Query& out) {
    const auto name = query.find("preset");
    if (name == query.end())
        return api::ApiError{"preset_required",
                             "this server serves named presets only: add preset=NAME"};
    for (const char* once : {"preset", "sig", "exp"})
        if (query.count(once) > 1)
            return api::ApiError{"invalid_parameter",
                                 "parameter '" + std::string(once) + "' is given more than once"};
    const auto preset = presets.find(name->second);
    if (preset == presets.end())
        return api::ApiError{"unknown_preset",
                             "no preset '" + name->second.substr(0, 40) + "' on this server"};
    for (const auto& [k, v] : query)
        if (k != "preset" && k != "sig" && k != "exp")
            return api::ApiError{"invalid_parameter",
                                 "with presets, a URL carries preset (and sig, exp) only, not '" +
                                     k.substr(0, 40) + "'"};
    if (!preset->second.format.empty() && !format.empty() && format != preset->second.format)
        return api::ApiError{"invalid_parameter", "preset '" + name->second + "' serves ." +
                                                      preset->second.format + ", not ." +
                                                      std::string(format)};
    out = preset->second.fields;
    return std::nullopt;
}

} // namespace textond::app
