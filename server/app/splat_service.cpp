#include "server/app/splat_service.h"

#include "api/texton_meta.h"
#include "server/io/image_io.h"
#include "server/io/splat_file.h"

namespace textond::app {

namespace {

// Layer k's weights: channel k of `weights` (R, G, B, A), then for layers 5 to 8 channel k - 4
// of `weights2`; channels past the last layer (A under three layers) are left out.
Result<core::Image> layer_weights(const std::vector<core::Image>& images, int layers) {
    const core::Image& first = images.front();
    for (const core::Image& im : images)
        if (im.channels > 4)
            return make_error(ErrorCode::invalid_argument,
                              "a weight image has at most 4 channels (R, G, B, A), not " +
                                  std::to_string(im.channels));
    if (images.size() > 1 && (images[1].width != first.width || images[1].height != first.height))
        return make_error(ErrorCode::invalid_argument,
                          "'weights' and 'weights2' must have the same size");
    if (images.size() > 1 && first.channels != 4)
        return make_error(ErrorCode::invalid_argument,
                          "with 'weights2', 'weights' must be RGBA (layers 1 to 4); it has " +
                              std::to_string(first.channels) + " channels");
    int channels = 0;
    for (const core::Image& im : images) channels += im.channels;
    if (channels < layers)
        return make_error(ErrorCode::invalid_argument,
                          "the weight images have " + std::to_string(channels) + " channels for " +
                              std::to_string(layers) +
                              " layers (an RGBA PNG holds four: R is layer 1, G 2, B 3, A 4)");
    core::Image w(first.width, first.height, layers);
    int k = 0;
    for (const core::Image& im : images)
        for (int c = 0; c < im.channels && k < layers; ++c, ++k)
            std::copy(im.plane(c), im.plane(c) + im.plane_size(), w.plane(k));
    return w;
}

} // namespace

Result<SplatService::Created> SplatService::create(const api::SplatRequest& request,
                                                   const std::vector<core::Image>& images) {
    const int layers = static_cast<int>(request.textons.size());
    io::SplatRecord record;
    record.weights = request.weights;
    record.height = request.height;
    std::string sha;
    if (record.weights.kind == core::SplatWeights::Kind::image) {
        if (images.empty())
            return make_error(ErrorCode::invalid_argument, "image weights need a 'weights' image");
        auto w = layer_weights(images, layers);
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
    auto prepared = m_splats.prepare(record); // every layer stored, and drawable
    if (!prepared) return prepared.error();
    meta.channels = prepared.value()->channels();
    meta.created = api::rfc3339_now();
    auto put = m_splats.put(record);
    if (!put) return put.error();
    return Created{meta, put.value()};
}

} // namespace textond::app
