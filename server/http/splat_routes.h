#pragma once
// Splat maps: POST /v1/splats (a multipart form: the layer textons and their weights, as images
// or rules; SplatService's workflow) and GET /v1/splats/{id}; their images are ImageRoutes'.
#include "server/app/splat_service.h"
#include "server/http/config.h"
#include "server/http/gate.h"
#include "server/http/imports.h"
#include "server/http/request_body.h"
#include "server/io/image_io.h"
#include "server/store/image_cache.h"
#include "server/store/splat_store.h"

#include <httplib.h>

#include <memory>
#include <optional>
#include <string_view>
#include <vector>

namespace textond::http {

class SplatRoutes {
public:
    SplatRoutes(const ServeConfig& config, SplatService& service, SplatStore& splats,
                ImageCache& cache, Gate& gate);

    using Req = const httplib::Request&;
    using Res = httplib::Response&;
    void create(Req req, Res res, const httplib::ContentReader& reader);
    void get(Req req, Res res);
    // DELETE: here, in the shared store (every replica) and in this replica's image cache.
    void remove(Req req, Res res);
    // Anything else under /v1/splats/: a bad id is a 400 (never a path), a good one a 404.
    static void fallback(Req req, Res res);

private:
    // What a creation from weight images holds from their headers to the files written: the
    // memory it will need (its weights' headers say how much) from the decode budget, and a
    // decoder slot. False when the refusal was sent.
    struct Admitted {
        std::optional<SlotGuard> slot;
        std::shared_ptr<BudgetLease> lease;
        std::vector<std::string_view> encoded;
        io::DecodeLimits limits;
    };
    bool admit_weights(Res res, const httplib::MultipartFormData* const* images, int sent,
                       int layers, Admitted& out);

    const ServeConfig& m_config;
    SplatService& m_service;
    SplatStore& m_splats;
    ImageCache& m_cache;
    Gate& m_gate;
};

} // namespace textond::http
