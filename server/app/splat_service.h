#pragma once
// The splat-map workflow without HTTP: the layers (and a rules height) must be stored textons;
// the weight images (one or two, RGBA = four layers each) become one channel a layer; the splat
// is prepared (so nothing is stored that cannot be drawn), named by its content and written.
// Nothing is analysed: it answers at once.
#include "api/requests.h"
#include "api/splat_meta.h"
#include "core/image.h"
#include "core/result.h"
#include "server/store/splat_store.h"

#include <vector>

namespace textond::app {

class SplatService {
public:
    explicit SplatService(store::SplatStore& splats) : m_splats(splats) {}

    struct Created {
        api::SplatMeta meta;
        bool created = false; // false: stored already
    };
    // `images`: the decoded weight images in order (none for rules).
    Result<Created> create(const api::SplatRequest& request,
                           const std::vector<core::Image>& images);

private:
    store::SplatStore& m_splats;
};

} // namespace textond::app
