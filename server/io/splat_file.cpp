#include "server/io/splat_file.h"

#include "server/io/image_io.h"
#include "server/io/sha256.h"

#include <filesystem>

namespace textond::io {

namespace {

Error bad(const std::string& path, const std::string& why) {
    return make_error(ErrorCode::io, "splat file " + path + ": " + why);
}

std::vector<std::string> weight_channel_names(int n) {
    std::vector<std::string> names;
    names.reserve(static_cast<std::size_t>(n));
    for (int c = 0; c < n; ++c) names.push_back("w" + std::to_string(c)); // sorted as stored
    return names;
}

} // namespace

std::string splat_id(const std::vector<std::string>& textons, const nlohmann::json& weights) {
    Sha256 h;
    h.update(core::kSplatVersion).update("\n");
    for (const std::string& t : textons) h.update(t).update("\n");
    h.update(weights.dump());
    return h.hex();
}

Result<bool> write_splat_files(const std::string& dir, const SplatRecord& r) {
    const std::string& id = r.meta.id;
    if (r.weights.kind == core::SplatWeights::Kind::image) {
        const core::Image& w = r.weights.image.weights;
        auto bytes = encode_image_memory(w, Encoding::exr, {}, 6, weight_channel_names(w.channels));
        if (!bytes) return bytes.error();
        auto ok = write_file_atomic(dir + "/" + id + ".weights.exr", bytes.value());
        if (!ok) return ok.error();
    }
    return write_file_atomic(dir + "/" + id + ".json", nlohmann::json(r.meta).dump(2) + "\n");
}

Result<SplatRecord> read_splat_files(const std::string& dir, const std::string& id) {
    const std::string path = dir + "/" + id + ".json";
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        return make_error(ErrorCode::not_found, "no splat " + id);
    auto text = read_file(path);
    if (!text) return bad(path, text.error().message);
    SplatRecord r;
    try {
        r.meta = nlohmann::json::parse(text.value()).get<api::SplatMeta>();
        r.weights = api::splat_weights_from_json(r.meta.weights, r.height);
        const int k = static_cast<int>(r.meta.textons.size());
        if (r.meta.id != id || r.meta.version != core::kSplatVersion)
            return bad(path, "id or version disagree with the file");
        if (r.weights.kind == core::SplatWeights::Kind::image) {
            DecodeLimits limits;
            limits.all_channels = true;
            auto w = decode_image_file(dir + "/" + id + ".weights.exr", limits);
            if (!w) return bad(path, "weights: " + w.error().message);
            r.weights.image.weights = std::move(w.value());
            if (pixels_sha256(r.weights.image.weights) !=
                    r.meta.weights.at("sha256").get<std::string>() ||
                r.weights.image.weights.channels != r.meta.weights.at("channels").get<int>())
                return bad(path, "weights checksum mismatch");
        }
        // Today's rules, not the writer's: what they refuse is never rendered.
        if (auto err = r.weights.validate(k)) return bad(path, err->message);
        if (splat_id(r.meta.textons, r.meta.weights) != id)
            return bad(path, "content does not hash to its id");
    } catch (const std::exception& e) {
        return bad(path, std::string("metadata: ") + e.what());
    }
    return r;
}

} // namespace textond::io
