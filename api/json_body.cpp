#include "api/json_body.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <string>
#include <vector>

namespace textond::api {

namespace {

using json = nlohmann::json;

// The SAX callbacks every handler below answers the same way.
struct BoundedSax : json::json_sax_t {
    explicit BoundedSax(int max_depth, std::size_t max_values)
        : m_max_depth(max_depth), m_max_values(max_values) {}

    bool value() {
        if (++m_values <= m_max_values) return true;
        fail("payload_too_large", "more than " + std::to_string(m_max_values) + " JSON values");
        return false;
    }
    bool open() {
        if (!value()) return false;
        if (++depth <= m_max_depth) return true;
        fail("invalid_body", "nested deeper than " + std::to_string(m_max_depth) + " levels");
        return false;
    }
    void fail(const char* code, std::string why) {
        if (!error) error = ApiError{code, std::move(why)};
    }

    bool null() override { return value(); }
    bool boolean(bool) override { return value(); }
    bool number_integer(number_integer_t) override { return value(); }
    bool number_unsigned(number_unsigned_t) override { return value(); }
    bool number_float(number_float_t, const string_t&) override { return value(); }
    bool string(string_t&) override { return value(); }
    bool binary(binary_t&) override { return value(); }
    bool start_object(std::size_t) override {
        m_keys.emplace_back();
        return open();
    }
    // A key given twice in one object: nlohmann would keep the last, so a body would mean
    // something else than what a reader of its first occurrence sees.
    bool key(string_t& k) override {
        if (!value()) return false;
        if (m_keys.empty()) return true;
        std::vector<std::string>& seen = m_keys.back();
        if (std::find(seen.begin(), seen.end(), k) != seen.end()) {
            fail("invalid_body", "key '" + k.substr(0, 40) + "' given twice in one object");
            return false;
        }
        seen.push_back(k);
        return true;
    }
    bool end_object() override {
        --depth;
        if (!m_keys.empty()) m_keys.pop_back();
        return true;
    }
    bool start_array(std::size_t) override { return open(); }
    bool end_array() override {
        --depth;
        return true;
    }
    bool parse_error(std::size_t position, const std::string&,
                     const nlohmann::detail::exception&) override {
        fail("invalid_body", "not JSON (at byte " + std::to_string(position) + ")");
        return false;
    }

    int depth = 0;
    std::optional<ApiError> error;

private:
    const int m_max_depth;
    const std::size_t m_max_values;
    std::size_t m_values = 0;
    std::vector<std::vector<std::string>> m_keys; // of each open object
};

// Depth 1: the object; 2: the points or normals array; 3: one point.
struct SurfaceSax final : BoundedSax {
    static constexpr const char* kObjectWanted =
        "the body must be a JSON object, {\"points\": [[x, y, z], ...], \"normals\": [[x, y, z], "
        "...]}";
    SurfaceSax(std::size_t max_points, std::vector<float>& p, std::vector<float>& n)
        : BoundedSax(3, 3 + 8 * max_points + 8), m_max_points(max_points), m_points(p),
          m_normals(n) {}

    bool shape(const std::string& why) {
        fail("invalid_body", why);
        return false;
    }
    bool number(double v) {
        if (!value()) return false;
        if (depth == 0) return shape(kObjectWanted);
        if (depth != 3 || !m_into) return shape("a coordinate outside a point");
        if (++m_coordinates > 3) return shape("a point has exactly three coordinates");
        m_into->push_back(static_cast<float>(v));
        return true;
    }
    bool null() override { return shape(depth == 0 ? kObjectWanted : "null in the body"); }
    bool boolean(bool) override {
        return shape(depth == 0 ? kObjectWanted : "true or false in the body");
    }
    bool string(string_t&) override {
        return shape(depth == 0 ? kObjectWanted : "a string where numbers belong");
    }
    bool binary(binary_t&) override { return shape("binary data in the body"); }
    bool number_integer(number_integer_t v) override { return number(static_cast<double>(v)); }
    bool number_unsigned(number_unsigned_t v) override { return number(static_cast<double>(v)); }
    bool number_float(number_float_t v, const string_t&) override { return number(v); }
    bool key(string_t& k) override {
        if (!value()) return false;
        if (k == "points")
            m_into = &m_points;
        else if (k == "normals")
            m_into = &m_normals;
        else
            return shape("unknown field '" + k.substr(0, 40) + "'");
        if (m_into->size() != 0 || (m_into == &m_points ? m_seen_points : m_seen_normals))
            return shape("field '" + k + "' given twice");
        (m_into == &m_points ? m_seen_points : m_seen_normals) = true;
        return true;
    }
    bool start_object(std::size_t) override {
        if (!open()) return false;
        return depth == 1 || shape("an object inside the body");
    }
    bool start_array(std::size_t) override {
        if (!open()) return false;
        if (depth == 1) return shape(kObjectWanted);
        if (depth == 3) {
            m_coordinates = 0;
            if (m_into->size() / 3 >= m_max_points) {
                fail("payload_too_large", "at most " + std::to_string(m_max_points) + " points");
                return false;
            }
        }
        return true;
    }
    bool end_array() override {
        if (depth == 3 && m_coordinates != 3) return shape("a point has exactly three coordinates");
        return BoundedSax::end_array();
    }

    const std::size_t m_max_points;
    std::vector<float>& m_points;
    std::vector<float>& m_normals;
    std::vector<float>* m_into = nullptr;
    int m_coordinates = 0;
    bool m_seen_points = false, m_seen_normals = false;
};

// nlohmann's reader takes a NUL byte for the end of the input, so `{...}\0anything` would pass;
// JSON text holds none (a string escapes it as \u0000).
std::optional<ApiError> no_nul(std::string_view body) {
    if (body.find('\0') == std::string_view::npos) return std::nullopt;
    return ApiError{"invalid_body", "not JSON: a NUL byte (write it as \\u0000 in a string)"};
}

} // namespace

std::optional<ApiError> check_json_bounds(std::string_view body, int max_depth,
                                          std::size_t max_values) {
    if (auto e = no_nul(body)) return e;
    BoundedSax sax(max_depth, max_values);
    if (json::sax_parse(body, &sax)) return std::nullopt;
    return sax.error ? sax.error : ApiError{"invalid_body", "not JSON"};
}

std::optional<ApiError> parse_surface_json(std::string_view body, std::size_t max_points,
                                           std::vector<float>& points,
                                           std::vector<float>& normals) {
    points.clear();
    normals.clear();
    if (auto e = no_nul(body)) return e;
    SurfaceSax sax(max_points, points, normals);
    const bool ok = json::sax_parse(body, &sax);
    std::optional<ApiError> e;
    if (!ok)
        e = sax.error ? sax.error : ApiError{"invalid_body", "not JSON"};
    else if (!sax.m_seen_points || !sax.m_seen_normals)
        e = ApiError{"invalid_body", "both points and normals are required"};
    else if (points.size() != normals.size())
        e = ApiError{"invalid_body", "points and normals must be arrays of equal length"};
    if (!e) return std::nullopt;
    points.clear();
    points.shrink_to_fit();
    normals.clear();
    normals.shrink_to_fit();
    e->message = "expected {\"points\": [[x,y,z],...], \"normals\": [[x,y,z],...]}: " + e->message;
    return e;
}

} // namespace textond::api
