#include "server/io/texton_file.h"

#include "server/io/image_io.h"
#include "server/io/sha256.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace textond::io {

namespace {
void hash_u32(Sha256& h, std::uint32_t v) {
    const unsigned char b[4] = {static_cast<unsigned char>(v), static_cast<unsigned char>(v >> 8),
                                static_cast<unsigned char>(v >> 16),
                                static_cast<unsigned char>(v >> 24)};
    h.update(b, 4);
}
void hash_floats(Sha256& h, const std::vector<float>& v) {
    // Little-endian float32 bytes; every supported platform (x86-64, arm64) is little-endian.
    h.update(v.data(), v.size() * sizeof(float));
}
Error bad_file(const std::string& path, const std::string& why) {
    return make_error(ErrorCode::unprocessable, "not a valid texton file " + path + ": " + why);
}

nlohmann::json marginals_json(const core::MarginalModel& m) {
    nlohmann::json j;
    std::vector<double> basis;
    for (int c = 0; c < m.channels; ++c)
        for (int i = 0; i < m.channels; ++i) basis.push_back(m.basis(c, i));
    j["basis"] = basis; // row c, column i: channel c of component i
    j["variance"] = std::vector<double>(m.variance.begin(), m.variance.begin() + m.channels);
    j["quantiles"] =
        std::vector<std::vector<float>>(m.quantiles.begin(), m.quantiles.begin() + m.channels);
    return j;
}

// The marginals of a texton with `channels` channels, or why they are not valid.
Result<core::MarginalModel> marginals_from_json(const nlohmann::json& j, int channels,
                                                const core::ChannelValues& mean) {
    core::MarginalModel m;
    m.channels = channels;
    m.mean = mean;
    m.basis.n = channels;
    const auto basis = j.at("basis").get<std::vector<double>>();
    const auto variance = j.at("variance").get<std::vector<double>>();
    const auto quantiles = j.at("quantiles").get<std::vector<std::vector<float>>>();
    const auto n = static_cast<std::size_t>(channels);
    if (basis.size() != n * n || variance.size() != n || quantiles.size() != n)
        return make_error(ErrorCode::unprocessable, "marginals have the wrong shape");
    for (std::size_t c = 0; c < n; ++c)
        for (std::size_t i = 0; i < n; ++i) {
            m.basis(static_cast<int>(c), static_cast<int>(i)) = basis[c * n + i];
            if (!std::isfinite(basis[c * n + i]))
                return make_error(ErrorCode::unprocessable, "marginal basis is not finite");
        }
    for (std::size_t i = 0; i < n; ++i) {
        const auto& q = quantiles[i];
        if (!(variance[i] >= 0.0) || q.size() != core::MarginalModel::kQuantiles)
            return make_error(ErrorCode::unprocessable, "marginal quantiles have the wrong shape");
        for (std::size_t k = 0; k < q.size(); ++k)
            if (!std::isfinite(q[k]) || (k > 0 && q[k] < q[k - 1]))
                return make_error(ErrorCode::unprocessable,
                                  "marginal quantiles are not finite and ascending");
        m.variance[i] = variance[i];
        m.quantiles[i] = q;
    }
    return m;
}
} // namespace

std::string texton_id(const core::Image& exemplar, const core::AnalysisParams& params,
                      const std::vector<api::MapMeta>& maps) {
    Sha256 h;
    h.update(std::string_view(core::kAnalysisVersion));
    h.update("\n", 1);
    hash_u32(h, static_cast<std::uint32_t>(exemplar.width));
    hash_u32(h, static_cast<std::uint32_t>(exemplar.height));
    hash_u32(h, static_cast<std::uint32_t>(exemplar.channels));
    hash_floats(h, exemplar.data);
    h.update(api::canonical_params(params).dump());
    // A large exemplar's texton comes from its working window (core/working_window.h): a
    // different computation than the whole exemplar's, so a different id.
    if (core::is_windowed(exemplar.width, exemplar.height, params.working_side))
        h.update("\nwindow " + std::to_string(params.working_side));
    // So does a window whose sides were brought down to fast FFT sizes (builds before that crop
    // transformed the sides as they were).
    const auto window =
        core::window_size(exemplar.width, exemplar.height, params.working_side, 2 * params.size);
    if (params.working_side > 0 &&
        window != std::array<int, 2>{std::min(exemplar.width, params.working_side),
                                     std::min(exemplar.height, params.working_side)})
        h.update("\nfft window " + std::to_string(window[0]) + "x" + std::to_string(window[1]));
    for (const api::MapMeta& m : maps)
        h.update("\nmap " + m.name + " " + std::to_string(m.channels) + " " +
                 std::to_string(m.bits));
    return h.hex();
}

std::string coefficients_sha256(const core::Texton& t) {
    Sha256 h;
    hash_floats(h, t.alpha.data);
    return h.hex();
}

TextonRecord make_record(const core::Image& exemplar, const core::AnalysisParams& params,
                         const core::AnalysisResult& result) {
    TextonRecord r;
    r.texton = result.texton;
    api::TextonMeta& m = r.meta;
    m.id = texton_id(exemplar, params);
    m.version = core::kAnalysisVersion;
    m.exemplar_width = exemplar.width;
    m.exemplar_height = exemplar.height;
    m.channels = exemplar.channels;
    m.mean = result.texton.mean;
    m.size = params.size;
    m.order = params.order;
    m.iterations = params.iterations;
    m.seed = params.seed;
    m.periodic = params.periodic;
    m.rme = result.rme;
    m.rme_uncorrected = result.rme_uncorrected;
    m.timings = result.timings;
    m.coefficients_sha256 = coefficients_sha256(result.texton);
    m.exemplar_marginals = !result.texton.marginals.empty();
    if (result.coherence) {
        m.phase_coherence = result.coherence->index;
        m.sharpness_index = result.coherence->full.index;
    }
    if (result.shape) m.shape_score = result.shape->score;
    return r;
}

TextonRecord make_set_record(const core::Image& stacked, std::vector<api::MapMeta> maps,
                             const core::AnalysisParams& params, const core::SetAnalysis& set) {
    TextonRecord r = make_record(stacked, params, set.result);
    for (std::size_t i = 0; i < maps.size(); ++i) {
        api::MapMeta& m = maps[i];
        m.rme = set.map_rme[i];
        m.range.clear();
        for (int c = m.first; c < m.first + m.channels; ++c) {
            const float* p = stacked.plane(c);
            const auto [lo, hi] = std::minmax_element(p, p + stacked.plane_size());
            m.range.push_back({*lo, *hi});
        }
    }
    r.meta.maps = std::move(maps);
    r.meta.id = texton_id(stacked, params, r.meta.maps);
    return r;
}

// A set's channels are named after its maps: albedo.R, albedo.G, albedo.B, height.Y, ...
// OpenEXR stores channels sorted by name, so these names, not the file's order, say which
// plane is which when the file is read back (ao.Y comes before height.Y on disk).
namespace {
std::vector<std::string> set_channel_names(const std::vector<api::MapMeta>& maps) {
    std::vector<std::string> names;
    for (const api::MapMeta& m : maps)
        for (int c = 0; c < m.channels; ++c)
            names.push_back(m.name + "." + (m.channels == 1 ? "Y" : std::string(1, "RGB"[c])));
    return names;
}
// The exemplar's marginals from the file's attribute, which the metadata says it has or not.
std::optional<std::string> read_marginals(const std::string& text, const api::TextonMeta& m,
                                          core::Texton& t) {
    if (text.empty() == m.exemplar_marginals)
        return "the metadata and the marginals attribute disagree";
    if (text.empty()) return std::nullopt;
    try {
        auto mm = marginals_from_json(nlohmann::json::parse(text), m.channels, m.mean);
        if (!mm) return mm.error().message;
        t.marginals = std::move(mm.value());
    } catch (const std::exception& e) {
        return std::string("marginals: ") + e.what();
    }
    return std::nullopt;
}

// Plane c of the texton is the file's channel source[c]: found by name for a set, the file's
// order otherwise. Why not, when a name is missing.
std::optional<std::string> plane_sources(const std::vector<std::string>& file_names,
                                         const api::TextonMeta& m, std::vector<int>& source) {
    source.resize(static_cast<std::size_t>(m.channels));
    for (int c = 0; c < m.channels; ++c) source[static_cast<std::size_t>(c)] = c;
    if (m.maps.empty()) return std::nullopt;
    const std::vector<std::string> names = set_channel_names(m.maps);
    if (names.size() != static_cast<std::size_t>(m.channels))
        return "the maps do not add up to the texton's channels";
    for (std::size_t c = 0; c < names.size(); ++c) {
        const auto it = std::find(file_names.begin(), file_names.end(), names[c]);
        if (it == file_names.end()) return "no channel " + names[c];
        source[c] = static_cast<int>(it - file_names.begin());
    }
    return std::nullopt;
}
} // namespace

Result<std::string> texton_file_bytes(const TextonRecord& record) {
    // Without provenance: two analyses of one exemplar give one file, byte for byte.
    std::vector<std::pair<std::string, std::string>> attributes = {
        {kMetaAttribute, api::file_meta_json(record.meta).dump()}};
    if (!record.texton.marginals.empty())
        attributes.emplace_back(kMarginalsAttribute,
                                marginals_json(record.texton.marginals).dump());
    return encode_image_memory(record.texton.alpha, Encoding::exr, attributes, 6,
                               set_channel_names(record.meta.maps));
}

Result<bool> write_texton_file(const std::string& path, const TextonRecord& record) {
    // Encoded in memory, then written by our own atomic write, which knows why a write failed
    // (a full disk is ErrorCode::no_space; OpenEXR's own writer only says "failed").
    auto bytes = texton_file_bytes(record);
    if (!bytes) return bytes.error();
    return write_file_atomic(path, bytes.value());
}

Result<TextonRecord> read_texton_file(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        return make_error(ErrorCode::not_found, "no such texton file: " + path);
    auto in = OIIO::ImageInput::open(path);
    if (!in) return bad_file(path, OIIO::geterror());
    const OIIO::ImageSpec& spec = in->spec();
    const std::string meta_text = spec.get_string_attribute(kMetaAttribute);
    if (meta_text.empty()) return bad_file(path, "no textond:meta attribute");
    TextonRecord r;
    try {
        r.meta = nlohmann::json::parse(meta_text).get<api::TextonMeta>();
    } catch (const std::exception& e) {
        return bad_file(path, std::string("metadata: ") + e.what());
    }
    const api::TextonMeta& m = r.meta;
    if (spec.width != m.size || spec.height != m.size || spec.nchannels != m.channels ||
        (m.maps.empty() && m.channels != 1 && m.channels != 3) || m.size <= 0)
        return bad_file(path, "pixel size or channels disagree with the metadata");
    std::vector<float> buf(static_cast<std::size_t>(m.size) * m.size * m.channels);
    if (!in->read_image(0, 0, 0, m.channels, OIIO::TypeDesc::FLOAT, buf.data()))
        return bad_file(path, in->geterror());
    r.texton.size = m.size;
    r.texton.channels = m.channels;
    r.texton.order = m.order;
    r.texton.mean = m.mean;
    r.texton.alpha = core::Image(m.size, m.size, m.channels);
    std::vector<int> source;
    if (auto why = plane_sources(spec.channelnames, m, source)) return bad_file(path, *why);
    const std::size_t n = r.texton.alpha.plane_size();
    for (std::size_t k = 0; k < n; ++k)
        for (int c = 0; c < m.channels; ++c)
            r.texton.alpha.plane(c)[k] =
                buf[k * m.channels + static_cast<std::size_t>(source[static_cast<std::size_t>(c)])];
    for (const api::MapMeta& mm : m.maps) r.texton.maps.push_back({mm.name, mm.first, mm.channels});
    if (!r.texton.maps.empty())
        if (auto err = core::validate_maps(r.texton.maps, m.channels))
            return bad_file(path, err->message);
    if (coefficients_sha256(r.texton) != m.coefficients_sha256)
        return bad_file(path, "coefficient checksum mismatch (damaged file)");
    // Today's rules for what may be rendered, whatever build wrote the file: the store
    // quarantines a file that fails them instead of serving it.
    if (m.size < 8 || m.size > 256 || !(m.order == 0 || m.order == 1 || m.order == 3))
        return bad_file(path, "size or interpolation order out of range");
    if (!std::all_of(m.mean.begin(), m.mean.begin() + m.channels,
                     [](double v) { return std::isfinite(v); }) ||
        !std::all_of(r.texton.alpha.data.begin(), r.texton.alpha.data.end(),
                     [](float v) { return std::isfinite(v); }))
        return bad_file(path, "mean colour or coefficients are not finite");
    if (auto why = read_marginals(spec.get_string_attribute(kMarginalsAttribute), m, r.texton))
        return bad_file(path, *why);
    return r;
}

std::string texton_v1_text(const TextonRecord& record, const std::string& name) {
    const core::Texton& t = record.texton;
    const int framed = t.size + 2; // the authors' viewer needs a zero frame around the texton
    std::string out;
    char line[128];
    auto channel = [&](int c) { return t.channels == 1 ? 0 : c; };
    std::snprintf(line, sizeof line, "TEXTON\n1\n%d\n%e %e %e\n%d %d", t.order,
                  t.mean[static_cast<std::size_t>(channel(0))],
                  t.mean[static_cast<std::size_t>(channel(1))],
                  t.mean[static_cast<std::size_t>(channel(2))], framed, framed);
    out += line;
    for (int fy = framed - 1; fy >= 0; --fy) // bottom row first (OpenGL texture order)
        for (int fx = 0; fx < framed; ++fx) {
            const int x = fx - 1, y = fy - 1;
            const bool inside = x >= 0 && y >= 0 && x < t.size && y < t.size;
            float v[3];
            for (int c = 0; c < 3; ++c) v[c] = inside ? t.alpha.at(channel(c), x, y) : 0.0f;
            std::snprintf(line, sizeof line, "\n%e %e %e", v[0], v[1], v[2]);
            out += line;
        }
    std::snprintf(line, sizeof line, " (%d x %d)", record.meta.exemplar_width,
                  record.meta.exemplar_height);
    out += "\nOriginal image: " + name + line;
    return out;
}

} // namespace textond::io
