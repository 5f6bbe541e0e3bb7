#include "server/io/obj_mesh.h"

#include <charconv>
#include <cmath>
#include <string>
#include <vector>

namespace textond::io {

namespace {

Error bad(std::size_t line, const std::string& why) {
    return make_error(ErrorCode::unprocessable, "OBJ line " + std::to_string(line) + ": " + why);
}

std::string_view next_token(std::string_view& s) {
    std::size_t b = s.find_first_not_of(" \t\r");
    if (b == std::string_view::npos) {
        s = {};
        return {};
    }
    s.remove_prefix(b);
    std::size_t e = s.find_first_of(" \t\r");
    const std::string_view t = s.substr(0, e);
    s.remove_prefix(e == std::string_view::npos ? s.size() : e);
    return t;
}

} // namespace

Result<core::TriangleMesh> parse_obj(std::string_view text) {
    core::TriangleMesh m;
    std::size_t line_no = 0;
    std::vector<long long> face;
    while (!text.empty()) {
        const std::size_t nl = text.find('\n');
        std::string_view line = text.substr(0, nl);
        text.remove_prefix(nl == std::string_view::npos ? text.size() : nl + 1);
        ++line_no;
        const std::string_view kind = next_token(line);
        if (kind == "v") {
            for (int d = 0; d < 3; ++d) {
                const std::string tok(next_token(line));
                char* end = nullptr;
                const float v = std::strtof(tok.c_str(), &end);
                if (tok.empty() || *end != '\0' || !std::isfinite(v))
                    return bad(line_no, "a vertex needs three finite numbers");
                m.positions.push_back(v);
            }
            if (m.positions.size() / 3 > kMaxObjVertices)
                return make_error(ErrorCode::too_large, "OBJ has more than " +
                                                            std::to_string(kMaxObjVertices) +
                                                            " vertices");
        } else if (kind == "f") {
            face.clear();
            for (std::string_view tok = next_token(line); !tok.empty(); tok = next_token(line)) {
                const std::string_view first = tok.substr(0, tok.find('/'));
                long long idx = 0;
                const auto r = std::from_chars(first.data(), first.data() + first.size(), idx);
                if (r.ec != std::errc() || r.ptr != first.data() + first.size() || idx == 0)
                    return bad(line_no, "bad face index '" + std::string(tok) + "'");
                const long long nv = static_cast<long long>(m.positions.size() / 3);
                const long long v = idx > 0 ? idx - 1 : nv + idx;
                if (v < 0 || v >= nv) return bad(line_no, "face index out of range");
                face.push_back(v);
            }
            if (face.size() < 3) return bad(line_no, "a face needs three vertices");
            for (std::size_t k = 1; k + 1 < face.size(); ++k)
                for (long long v : {face[0], face[k], face[k + 1]})
                    m.triangles.push_back(static_cast<std::uint32_t>(v));
            if (m.triangles.size() / 3 > kMaxObjTriangles)
                return make_error(ErrorCode::too_large, "OBJ has more than " +
                                                            std::to_string(kMaxObjTriangles) +
                                                            " triangles");
        }
        // vt, vn, o, g, s, usemtl, mtllib, comments: not needed.
    }
    if (m.triangles.empty()) return make_error(ErrorCode::unprocessable, "OBJ has no faces");
    core::smooth_normals(m);
    return m;
}

} // namespace textond::io
