// libFuzzer target past decoding: the request parsers of api/ on arbitrary paths and
// queries, and what they accept fed onward. A mix field is evaluated (rho and its level, which
// once indexed past the levels with a NaN); surface parameters go through the input check. Any
// error message must survive api::printable into strict JSON. Selector 6 is the framing
// property: a stream of requests through the service's connection loop (framing_property.cpp).
#include "api/requests.h"
#include "api/safe_text.h"
#include "core/texture_mix.h"
#include "server/http/errors.h"
#include "tests/fuzz/framing_property.h"
#include "tests/fuzz/fuzz_query.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

namespace {

void check_message(const std::optional<textond::api::ApiError>& e) {
    if (!e) return;
    const std::string shown = textond::api::printable(e->message, 1024);
    // Throws (and so aborts the fuzzer) on invalid UTF-8: what used to be a 500.
    const std::string body = nlohmann::json{{"message", shown}}.dump();
    // A parser error is the client's: a 4xx by the server's one table (an unknown code is 500).
    const int status = textond::http::http_status(e->code);
    if (body.empty() || status < 400 || status > 499) __builtin_trap();
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace textond;
    const std::string_view in(reinterpret_cast<const char*>(data), size);
    // Layout: selector byte, then "path pieces|query" with '/' between pieces.
    if (in.empty()) return 0;
    const unsigned selector = static_cast<unsigned char>(in[0]) % 7;
    if (selector == 6) {
        test::check_framing_property(data + 1, size - 1);
        return 0;
    }
    const std::string_view rest = in.substr(1);
    const std::size_t bar = rest.find('|');
    const std::string_view path = rest.substr(0, bar);
    const api::Query q =
        test::query_of(bar == std::string_view::npos ? "" : rest.substr(bar + 1), true);
    std::vector<std::string_view> p;
    for (std::size_t pos = 0; pos <= path.size() && p.size() < 5;) {
        std::size_t end = path.find('/', pos);
        if (end == std::string_view::npos) end = path.size();
        p.push_back(path.substr(pos, end - pos));
        pos = end + 1;
    }
    while (p.size() < 5) p.push_back("");
    const std::string id(64, 'a');
    api::Limits limits;
    switch (selector) {
    case 0: {
        api::TileRequest t;
        auto e = api::parse_tile(id, p[0], p[1], p[2], p[3], q, t);
        check_message(e);
        // An accepted tile lies on the plane: its window's far corner does not overflow.
        if (!e && (t.x0() > (std::int64_t{1} << 62) || t.y0() < -(std::int64_t{1} << 62)))
            __builtin_trap();
        break;
    }
    case 1: {
        api::TileRequest t;
        check_message(api::parse_map_tile(id, p[0], p[1], p[2], p[3], q, t));
        break;
    }
    case 2: {
        api::RegionRequest r;
        check_message(api::parse_region(p[0], p[1], q, limits, r));
        break;
    }
    case 3: {
        api::MixRequest m;
        auto e = api::parse_mix(q, false, m);
        check_message(e);
        if (e) break;
        // Accepted fields evaluate to a weight in [0, 1] and a level in range anywhere.
        for (double x : {0.0, -4.6e18, 4.6e18, 12345.678})
            for (double y : {0.0, -4.6e18, 4.6e18}) {
                const double rho = m.field.rho(x, y);
                if (!(rho >= 0.0 && rho <= 1.0)) __builtin_trap();
                const int l = core::mix_level(rho, m.levels);
                if (l < 0 || l >= m.levels) __builtin_trap();
            }
        break;
    }
    case 4: {
        api::SurfaceParams s;
        check_message(api::parse_surface(id, q, p[0] == "mesh", s));
        break;
    }
    default: {
        core::AnalysisParams a;
        check_message(api::parse_analysis(q, a));
        api::ListRequest l;
        check_message(api::parse_list(q, l));
        // mix_level on any double: NaN, infinities, huge.
        double v = 0;
        std::memcpy(&v, rest.data(), std::min(rest.size(), sizeof v));
        const int lv = core::mix_level(std::isnan(v) ? 0.0 : v, 21);
        if (lv < 0 || lv > 20) __builtin_trap();
    }
    }
    return 0;
}
