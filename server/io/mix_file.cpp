#include "server/io/mix_file.h"

#include "api/requests.h"
#include "server/io/image_io.h"
#include "server/io/sha256.h"

#include <OpenImageIO/imageio.h>

#include <cstdio>
#include <filesystem>

namespace textond::io {

namespace OIIO = OIIO_NAMESPACE;

namespace {

Error bad(const std::string& path, const std::string& why) {
    return make_error(ErrorCode::io, "mix file " + path + ": " + why);
}

} // namespace

nlohmann::json field_json(const core::MixField& f) {
    if (f.kind == core::MixField::Kind::ramp)
        return {{"kind", "ramp"}, {"x0", f.x0}, {"y0", f.y0},
                {"dx", f.dx},     {"dy", f.dy}, {"width", f.width}};
    return {{"kind", "mask"},
            {"x0", f.x0},
            {"y0", f.y0},
            {"scale", f.scale},
            {"width", f.mask.width},
            {"height", f.mask.height},
            {"sha256", pixels_sha256(f.mask)}};
}

std::string mix_id(const std::string& u, const std::string& v, int levels, const core::MixField& f,
                   const std::optional<std::array<int, 2>>& fft_grid) {
    Sha256 h;
    h.update(core::kMixVersion).update("\n").update(u).update("\n").update(v).update("\n");
    h.update(std::to_string(levels)).update("\n");
    if (f.kind == core::MixField::Kind::ramp)
        h.update("ramp " + api::exact_text(f.x0) + " " + api::exact_text(f.y0) + " " +
                 api::exact_text(f.dx) + " " + api::exact_text(f.dy) + " " +
                 api::exact_text(f.width));
    else
        h.update("mask " + api::exact_text(f.x0) + " " + api::exact_text(f.y0) + " " +
                 api::exact_text(f.scale) + " " + pixels_sha256(f.mask));
    if (fft_grid)
        h.update("\nfft grid " + std::to_string((*fft_grid)[0]) + "x" +
                 std::to_string((*fft_grid)[1]));
    return h.hex();
}

namespace {
// The levels' floats as the file stores them (level by level, rows, pixels, channels) and the
// means and RME of the metadata.
std::string levels_digest(const std::vector<float>& interleaved, const api::MixMeta& meta) {
    std::string data(reinterpret_cast<const char*>(interleaved.data()),
                     interleaved.size() * sizeof(float));
    data += nlohmann::json(meta.means).dump();
    data += nlohmann::json(meta.rme).dump();
    return sha256_hex(data);
}
} // namespace

Result<bool> write_mix_files(const std::string& dir, const MixRecord& r) {
    const std::string& id = r.meta.id;
    const std::string mask = dir + "/" + id + ".mask.exr";
    if (r.field.kind == core::MixField::Kind::mask) {
        // Encoded in memory and written as every stored file is: a full disk is no_space (507,
        // and /readyz's store.no_space), where OpenImageIO's own writer said only io.
        auto bytes = encode_image_memory(r.field.mask, Encoding::exr);
        if (!bytes) return bytes.error();
        if (auto ok = write_file_atomic(mask, bytes.value()); !ok) return ok.error();
    }
    const core::Texton& first = r.levels.front();
    const int n = first.size, nl = static_cast<int>(r.levels.size());
    core::Image stack(n, n * nl, first.channels);
    for (int l = 0; l < nl; ++l)
        for (int c = 0; c < first.channels; ++c)
            for (int y = 0; y < n; ++y)
                for (int x = 0; x < n; ++x)
                    stack.at(c, x, l * n + y) =
                        r.levels[static_cast<std::size_t>(l)].alpha.at(c, x, y);
    std::vector<float> interleaved(static_cast<std::size_t>(n) * n * nl * first.channels);
    for (int l = 0; l < nl; ++l)
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x)
                for (int c = 0; c < first.channels; ++c)
                    interleaved[((static_cast<std::size_t>(l) * n + y) * n + x) * first.channels +
                                c] = stack.at(c, x, l * n + y);
    auto bytes = encode_image_memory(stack, Encoding::exr,
                                     {{kMixAttribute, nlohmann::json(r.meta).dump()},
                                      {kMixLevelsAttribute, levels_digest(interleaved, r.meta)}});
    auto written = bytes ? write_file_atomic(dir + "/" + id + ".exr", bytes.value())
                         : Result<bool>(bytes.error());
    if (!written && r.field.kind == core::MixField::Kind::mask) {
        std::error_code ec; // a mask without its levels is no mix (a full disk had left it)
        std::filesystem::remove(mask, ec);
    }
    return written;
}

namespace {

// The levels stacked vertically in the file, each n x n, with their means from the metadata.
std::vector<core::Texton> levels_of(const std::vector<float>& buf, const api::MixMeta& meta) {
    const int n = meta.size, nc = meta.channels;
    std::vector<core::Texton> levels;
    for (int l = 0; l < meta.levels; ++l) {
        core::Texton t;
        t.size = n;
        t.channels = nc;
        t.order = meta.order;
        for (int c = 0; c < nc; ++c)
            t.mean[static_cast<std::size_t>(c)] =
                meta.means.at(static_cast<std::size_t>(l)).at(static_cast<std::size_t>(c));
        t.alpha = core::Image(n, n, nc);
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x)
                for (int c = 0; c < nc; ++c)
                    t.alpha.at(c, x, y) =
                        buf[((static_cast<std::size_t>(l) * n + y) * n + x) * nc + c];
        levels.push_back(std::move(t));
    }
    return levels;
}

// The field the metadata describes; a mask is read from its own file and checked against its
// checksum. Throws on missing keys (the caller reports them as unreadable metadata).
Result<core::MixField> field_of(const nlohmann::json& f, const std::string& mask_path) {
    core::MixField field;
    field.x0 = f.at("x0");
    field.y0 = f.at("y0");
    if (f.at("kind") == "ramp") {
        field.dx = f.at("dx");
        field.dy = f.at("dy");
        field.width = f.at("width");
        return field;
    }
    field.kind = core::MixField::Kind::mask;
    field.scale = f.at("scale");
    auto mask = decode_image_file(mask_path);
    if (!mask) return make_error(ErrorCode::invalid_argument, "mask: " + mask.error().message);
    field.mask = std::move(mask.value());
    if (pixels_sha256(field.mask) != f.at("sha256").get<std::string>())
        return make_error(ErrorCode::invalid_argument, "mask checksum mismatch");
    return field;
}

} // namespace

Result<MixRecord> read_mix_files(const std::string& dir, const std::string& id, bool levels_only) {
    const std::string path = dir + "/" + id + ".exr";
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        return make_error(ErrorCode::not_found, "no mix " + id);
    auto in = OIIO::ImageInput::open(path);
    if (!in) return bad(path, OIIO::geterror());
    const OIIO::ImageSpec& spec = in->spec();
    MixRecord r;
    try {
        r.meta =
            nlohmann::json::parse(spec.get_string_attribute(kMixAttribute)).get<api::MixMeta>();
        const int n = r.meta.size, nl = r.meta.levels, nc = r.meta.channels;
        const int order = r.meta.order;
        // Today's rules, not the writer's: a file from an older build (or edited on disk) that
        // they refuse is never rendered (server/store/mix_store.cpp quarantines it).
        if (n < 8 || n > 256 || nl < 2 || nl > core::kMaxMixLevels || (nc != 1 && nc != 3) ||
            !(order == 0 || order == 1 || order == 3))
            return bad(path, "size, levels, channels or order out of range");
        if (r.meta.id != id || static_cast<int>(r.meta.means.size()) != nl || spec.width != n ||
            spec.height != n * nl || spec.nchannels != nc)
            return bad(path, "size, levels or id disagree with the metadata");
        std::vector<float> buf(static_cast<std::size_t>(n) * n * nl * nc);
        if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::FLOAT, buf.data()))
            return bad(path, in->geterror());
        const std::string digest = spec.get_string_attribute(kMixLevelsAttribute);
        if (!digest.empty()) {
            if (digest != levels_digest(buf, r.meta))
                return bad(path, "levels or their means and RME differ from their checksum");
            r.levels_verified = true;
        }
        r.levels = levels_of(buf, r.meta);
        if (levels_only) return r;
        auto field = field_of(r.meta.field, dir + "/" + id + ".mask.exr");
        if (!field) return bad(path, field.error().message);
        r.field = std::move(field.value());
        if (auto err = r.field.validate()) return bad(path, "field: " + err->message);
        // Of a grid cropped to a fast FFT size, or (older builds, or no crop) not.
        if (mix_id(r.meta.u, r.meta.v, nl, r.field) != id &&
            mix_id(r.meta.u, r.meta.v, nl, r.field, r.meta.grid) != id)
            return bad(path, "content does not hash to its id");
    } catch (const std::exception& e) {
        return bad(path, std::string("metadata: ") + e.what());
    }
    return r;
}

} // namespace textond::io
