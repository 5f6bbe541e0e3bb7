#include "server/app/splat_service.h"

#include "api/texton_meta.h"
#include "server/io/image_io.h"
#include "server/io/splat_file.h"

#include <algorithm>

namespace textond::app {

namespace {

// Layer k's weights: channel k of `weights` (R, G, B, A), then for layers 5 to 8 channel k - 4
// of `weights2`; channels past the last layer (A under three layers) are left out. The images are
// decoded one at a time into the layers' planes, so at most one decoded image is held beside them.
Result<core::Image> layer_weights(const std::vector<std::string_view>& encoded,
                                  const io::DecodeLimits& limits, int layers) {
    core::Image w;
    int k = 0, channels = 0;
    for (std::size_t i = 0; i < encoded.size(); ++i) {
        auto decoded = io::decode_image_memory(encoded[i], limits);
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

} // namespace

std::size_t SplatService::creation_bytes(const std::vector<io::ImageHeader>& headers, int layers) {
    if (headers.empty()) return 0;
    const std::size_t pixels =
        static_cast<std::size_t>(headers[0].width) * static_cast<std::size_t>(headers[0].height);
    std::size_t decode = 0; // the reader's interleaved floats and the decoded planes
    for (const io::ImageHeader& h : headers)
        decode = std::max(decode, pixels * static_cast<std::size_t>(h.channels) * 2 * 4);
    const std::size_t planes = pixels * static_cast<std::size_t>(layers) * 4;
    // The layers' planes beside a decode, then beside the EXR encoder's interleaved copy and
    // its output.
    return planes + std::max(decode, 2 * planes);
}

Result<SplatService::Created> SplatService::create(const api::SplatRequest& request,
                                                   const std::vector<std::string_view>& images,
                                                   const io::DecodeLimits& limits) {
    const int layers = static_cast<int>(request.textons.size());
    io::SplatRecord record;
    record.weights = request.weights;
    record.height = request.height;
    std::string sha;
    if (record.weights.kind == core::SplatWeights::Kind::image) {
        if (images.empty())
            return make_error(ErrorCode::invalid_argument, "image weights need a 'weights' image");
        auto w = layer_weights(images, limits, layers);
        if (!w) return w.error();
        record.weights.image.weights = std::move(w.value());
        sha = io::pixels_sha256(record.weights.image.weights);
    }
    if (auto err = record.weights.validate(layers)) return *err;
    api::SplatMeta& meta = record.meta;
    meta.version = core::kSplatVersion;
    meta.textons = request.textons;
    meta.weights = api::splat_weights_json(record.weights, sha, record.height);
    meta.id = io::splat_id(meta.textons, meta.weights);
    if (m_splats.contains(meta.id)) {
        auto known = m_splats.meta(meta.id);
        if (!known) return known.error();
        return Created{known.value(), false};
    }
    {
        auto prepared = m_splats.prepare(record); // every layer stored, and drawable
        if (!prepared) return prepared.error();
        meta.channels = prepared.value()->channels();
    } // its copy of the weights goes before the files are encoded
    meta.created = api::rfc3339_now();
    auto put = m_splats.put(record);
    if (!put) return put.error();
    return Created{meta, put.value()};
}

} // namespace textond::app
