#pragma once
// Surface noise over HTTP (texton-noise section 6): the bodies (points as JSON or float32, an OBJ
// mesh) read and admitted through the Gate at the cost SurfaceService knows before it runs. They
// are POSTs, so with --api-key they need its holder like every POST: an image URL's signature
// cannot cover a body, and these are the dearest renders a client can ask for.
#include "server/app/surface_service.h"
#include "server/http/gate.h"
#include "server/http/imports.h"
#include "server/store/texton_store.h"

#include <httplib.h>

#include <string>

namespace textond::http {

class SurfaceRoutes {
public:
    SurfaceRoutes(TextonStore& store, SurfaceService& surfaces, Gate& gate, std::string api_key);

    using Req = const httplib::Request&;
    using Res = httplib::Response&;
    void points(Req req, Res res, const httplib::ContentReader& reader);
    void mesh(Req req, Res res, const httplib::ContentReader& reader);

private:
    TextonStore& m_store;
    SurfaceService& m_surfaces;
    Gate& m_gate;
    std::string m_api_key;
};

} // namespace textond::http
