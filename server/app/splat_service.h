#pragma once
// The splat-map workflow without HTTP: the layers (and a rules height) must be stored textons;
// the weight images (one or two, RGBA = four layers each) become one channel a layer, and are
// kept as uploaded (server/io/splat_file.h); the splat is prepared (so nothing is stored that
// cannot be drawn), named by its content and written. Nothing is analysed: it answers at once.
#include "api/requests.h"
#include "api/splat_meta.h"
#include "core/image.h"
#include "core/result.h"
#include "server/io/image_io.h"
#include "server/store/splat_store.h"

#include <cstddef>
#include <string_view>
#include <vector>

namespace textond::app {

class SplatService {
public:
    explicit SplatService(store::SplatStore& splats) : m_splats(splats) {}

    struct Created {
        api::SplatMeta meta;
        bool created = false; // false: stored already
    };
    // `images`: the encoded weight images in order (none for rules), decoded here one at a time.
    Result<Created> create(const api::SplatRequest& request,
                           const std::vector<std::string_view>& images,
                           const io::DecodeLimits& limits);
    // The memory a creation holds at its peak, from its weight images' headers: admission
    // reserves it before a pixel is decoded.
    static std::size_t creation_bytes(const std::vector<io::ImageHeader>& headers, int layers);

private:
    store::SplatStore& m_splats;
};

} // namespace textond::app
