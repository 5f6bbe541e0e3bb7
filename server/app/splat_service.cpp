#include "server/app/splat_service.h"

#include "api/texton_meta.h"
#include "server/io/image_io.h"
#include "server/io/splat_file.h"

#include <algorithm>

namespace textond::app {

std::size_t SplatService::creation_bytes(const std::vector<io::ImageHeader>& headers, int layers) {
    if (headers.empty()) return 0;
    const std::size_t pixels =
        static_cast<std::size_t>(headers[0].width) * static_cast<std::size_t>(headers[0].height);
    std::size_t decode = 0; // one image's decode (its planes, a band and the reader's piece)
    for (const io::ImageHeader& h : headers) decode = std::max(decode, h.decode_bytes);
    // The layers' planes beside one decode (the images are stored as uploaded, not encoded).
    return pixels * static_cast<std::size_t>(layers) * 4 + decode;
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
        auto w = io::decode_splat_weights(images, limits, layers);
        if (!w) return w.error();
        record.weight_uploads.assign(images.begin(), images.end());
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
