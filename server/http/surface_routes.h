#pragma once
// Surface noise over HTTP (texton-noise section 6): colours at 3D points with normals, and a
// preview of an OBJ mesh textured by it. The work is one call of the renderer (CPU), admitted
// through the Gate at a cost known before it runs.
#include "render/renderer.h"
#include "server/http/gate.h"
#include "server/http/texton_store.h"

#include <httplib.h>

namespace textond::http {

class SurfaceRoutes {
public:
    SurfaceRoutes(TextonStore& store, render::Renderer& renderer, Gate& gate);

    using Req = const httplib::Request&;
    using Res = httplib::Response&;
    void points(Req req, Res res, const httplib::ContentReader& reader);
    void mesh(Req req, Res res, const httplib::ContentReader& reader);

private:
    TextonStore& m_store;
    render::Renderer& m_renderer;
    Gate& m_gate;
};

} // namespace textond::http
