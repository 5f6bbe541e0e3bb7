#include "server/io/splat_file.h"

#include "server/io/image_io.h"
#include "server/io/sha256.h"

#include <filesystem>
#include <string_view>
#include <vector>

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

DecodeLimits splat_weight_limits(const std::vector<std::string>& formats) {
    DecodeLimits limits;
    limits.max_pixels = static_cast<std::uint64_t>(core::kMaxSplatWeightPixels);
    limits.formats = formats;
    limits.all_channels = true; // RGBA: four layers
    return limits;
}

Result<core::Image> decode_splat_weights(const std::vector<std::string_view>& encoded,
                                         const DecodeLimits& limits, int layers) {
    core::Image w;
    int k = 0, channels = 0;
    for (std::size_t i = 0; i < encoded.size(); ++i) {
        auto decoded = decode_image_memory(encoded[i], limits);
        if (!decoded) return decoded.error();
        const core::Image& im = decoded.value();
        if (im.channels > 4)
            return make_error(ErrorCode::invalid_argument,
                              "a weight image has at most 4 channels (R, G, B, A), not " +
                                  std::to_string(im.channels));
        if (i == 0) {
            if (encoded.size() > 1 && im.channels != 4)
                return make_error(ErrorCode::invalid_argument,
                                  "with 'weights2', 'weights' must be RGBA (layers 1 to 4); it "
                                  "has " +
                                      std::to_string(im.channels) + " channels");
            w = core::Image(im.width, im.height, layers);
        } else if (im.width != w.width || im.height != w.height) {
            return make_error(ErrorCode::invalid_argument,
                              "'weights' and 'weights2' must have the same size");
        }
        channels += im.channels;
        for (int c = 0; c < im.channels && k < layers; ++c, ++k)
            std::copy(im.plane(c), im.plane(c) + im.plane_size(), w.plane(k));
    }
    if (channels < layers)
        return make_error(ErrorCode::invalid_argument,
                          "the weight images have " + std::to_string(channels) + " channels for " +
                              std::to_string(layers) +
                              " layers (an RGBA PNG holds four: R is layer 1, G 2, B 3, A 4)");
    return w;
}

std::string splat_id(const std::vector<std::string>& textons, const nlohmann::json& weights) {
    Sha256 h;
    h.update(core::kSplatVersion).update("\n");
    for (const std::string& t : textons) h.update(t).update("\n");
    h.update(weights.dump());
    return h.hex();
}

Result<bool> write_splat_files(const std::string& dir, const SplatRecord& r) {
    const std::string& id = r.meta.id;
    // What this call wrote goes again when a later file fails (a full disk): a weights file
    // without its metadata is no splat, and had stayed on disk.
    std::vector<std::string> written;
    auto write = [&](const std::string& path, std::string_view bytes) -> Result<bool> {
        auto ok = write_file_atomic(path, bytes);
        if (!ok) {
            std::error_code ec;
            for (const std::string& w : written) std::filesystem::remove(w, ec);
            return ok.error();
        }
        written.push_back(path);
        return true;
    };
    if (r.weights.kind == core::SplatWeights::Kind::image && !r.weight_uploads.empty()) {
        for (std::size_t i = 0; i < r.weight_uploads.size(); ++i) {
            std::string path = dir;
            path.append("/").append(id).append(i == 0 ? ".weights.upload" : ".weights2.upload");
            if (auto ok = write(path, r.weight_uploads[i]); !ok) return ok.error();
        }
    } else if (r.weights.kind == core::SplatWeights::Kind::image) {
        const core::Image& w = r.weights.image.weights;
        auto bytes = encode_image_memory(w, Encoding::exr, {}, 6, weight_channel_names(w.channels));
        if (!bytes) return bytes.error();
        if (auto ok = write(dir + "/" + id + ".weights.exr", bytes.value()); !ok) return ok.error();
    }
    return write(dir + "/" + id + ".json", nlohmann::json(r.meta).dump(2) + "\n");
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
            const std::string upload = dir + "/" + id + ".weights.upload";
            Result<core::Image> w = make_error(ErrorCode::io, "no weights");
            if (std::filesystem::is_regular_file(upload, ec)) {
                std::vector<std::string> bytes;
                for (const char* name : {".weights.upload", ".weights2.upload"}) {
                    std::string file = dir;
                    file.append("/").append(id).append(name);
                    if (!std::filesystem::is_regular_file(file, ec)) continue;
                    auto b = read_file(file);
                    if (!b) return bad(path, "weights: " + b.error().message);
                    bytes.push_back(std::move(b.value()));
                }
                w = decode_splat_weights({bytes.begin(), bytes.end()}, splat_weight_limits(), k);
            } else { // stored before the uploads were kept
                DecodeLimits limits;
                limits.all_channels = true;
                w = decode_image_file(dir + "/" + id + ".weights.exr", limits);
            }
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
