// The route table of api/openapi.yaml. cpp-httplib tries the routes of one method in the order
// they were added, first match wins: every specific route (their patterns do not overlap, so
// their order is free) before the /v1/textons/*, /v1/mixes/* and /v1/splats/* fallbacks, and a
// catch-all POST last.
#include "server/http/request_context.h"
#include "server/http/responses.h"
#include "server/http/textond_server.h"

namespace textond::http {

namespace {
using Req = const httplib::Request&;
using Res = httplib::Response&;
using Reader = const httplib::ContentReader&;

// A handler that calls `method` of `group`.
template <class Group>
httplib::Server::Handler call(Group* group, void (Group::*method)(Req, Res)) {
    return [group, method](Req req, Res res) { (group->*method)(req, res); };
}
template <class Group>
httplib::Server::HandlerWithContentReader call(Group* group,
                                               void (Group::*method)(Req, Res, Reader)) {
    return [group, method](Req req, Res res, Reader reader) { (group->*method)(req, res, reader); };
}
} // namespace

void TextondServer::install_routes() {
    install_get_routes();
    TextonRoutes* t = m_texton_routes.get();
    m_http.Post("/v1/textons", call(t, &TextonRoutes::upload));
    m_http.Post(R"(/v1/textons/([^/]+)/surface)",
                call(m_surface_routes.get(), &SurfaceRoutes::points));
    m_http.Post(R"(/v1/textons/([^/]+)/mesh\.png)",
                call(m_surface_routes.get(), &SurfaceRoutes::mesh));
    // Content-reader fallbacks, so that cpp-httplib never reads a body nobody asked for.
    m_http.Post(R"(/v1/textons/(.*))",
                [](Req req, Res res, Reader) { TextonRoutes::fallback(req, res); });
    m_http.Post("/v1/mixes", call(m_mix_routes.get(), &MixRoutes::create));
    m_http.Post("/v1/sign", call(m_sign_routes.get(), &SignRoutes::sign));
    m_http.Post(R"(/v1/mixes/(.*))",
                [](Req req, Res res, Reader) { MixRoutes::fallback(req, res); });
    m_http.Post("/v1/splats", call(m_splat_routes.get(), &SplatRoutes::create));
    m_http.Post(R"(/v1/splats/(.*))",
                [](Req req, Res res, Reader) { SplatRoutes::fallback(req, res); });
    m_http.Post(R"(.*)", [](Req, Res res, Reader) {
        set_route("unmatched");
        send_error(res, {"not_found", "no such endpoint"});
    });
    m_http.Delete(R"(/v1/textons/([^/]+))", call(t, &TextonRoutes::remove));
    m_http.Delete(R"(/v1/textons/(.*))", &TextonRoutes::fallback);
    m_http.Delete(R"(/v1/mixes/([^/]+))", call(m_mix_routes.get(), &MixRoutes::remove));
    m_http.Delete(R"(/v1/mixes/(.*))", &MixRoutes::fallback);
    m_http.Delete(R"(/v1/splats/([^/]+))", call(m_splat_routes.get(), &SplatRoutes::remove));
    m_http.Delete(R"(/v1/splats/(.*))", &SplatRoutes::fallback);
}

void install_image_routes(httplib::Server& http, ImageRoutes& images, ImageSource& source) {
    ImageRoutes* i = &images;
    using api::parse_map_tile;
    using api::parse_tile;
    const std::string c = "/v1/" + std::string(source.collection()) + "/";
    http.Get(c + R"(([^/]+)/tiles/([^/]+)/([^/]+)/([^/.]+)\.([a-z0-9]+))",
             i->tile(source, "{id}/tiles/{z}/{x}/{y}.{format}", &parse_tile));
    http.Get(c + R"(([^/]+)/map/([^/]+)/([^/]+)/([^/.]+)\.([a-z0-9]+))",
             i->tile(source, "{id}/map/{z}/{x}/{y}.{format}", &parse_map_tile));
    // Extension-less tiles: the format from Accept (AVIF, WebP or PNG), with Vary: Accept.
    http.Get(c + R"(([^/]+)/tiles/([^/]+)/([^/]+)/([^/.]+))",
             i->tile(source, "{id}/tiles/{z}/{x}/{y}", &parse_tile));
    http.Get(c + R"(([^/]+)/map/([^/]+)/([^/]+)/([^/.]+))",
             i->tile(source, "{id}/map/{z}/{x}/{y}", &parse_map_tile));
    http.Get(c + R"(([^/]+)/region\.([a-z0-9]+))", i->region(source, "{id}/region.{format}"));
    http.Get(c + R"(([^/]+)/tilejson\.json)", i->tilejson(source));
    if (source.has_report()) http.Get(c + R"(([^/]+)/quality\.png)", i->report(source));
}

void TextondServer::install_get_routes() {
    ImageRoutes* i = m_image_routes.get();
    for (const auto& source : m_sources) install_image_routes(m_http, *i, *source);
    // What only a texton has.
    m_http.Get(R"(/v1/textons/([^/]+)/tileable\.([a-z0-9]+))", call(i, &ImageRoutes::tileable));
    m_http.Get(R"(/v1/textons/([^/]+)/spectrum\.png)", call(i, &ImageRoutes::spectrum));
    m_http.Get(R"(/v1/textons/([^/]+)/quality\.json)", call(i, &ImageRoutes::quality));
    m_http.Get(R"(/v1/textons/([^/]+)/exemplar\.png)", call(i, &ImageRoutes::exemplar));
    TextonRoutes* t = m_texton_routes.get();
    m_http.Get("/v1/textons", call(t, &TextonRoutes::list));
    m_http.Get(R"(/v1/textons/([^/]+))", call(t, &TextonRoutes::get));
    m_http.Get(R"(/v1/textons/([^/]+)/status)", call(t, &TextonRoutes::status));
    m_http.Get(R"(/v1/textons/([^/]+)/kit\.tar)", call(i, &ImageRoutes::kit));
    m_http.Get(R"(/v1/textons/([^/]+)/texton\.([a-z0-9]+))", call(t, &TextonRoutes::file));
    m_http.Get(R"(/v1/textons/(.*))", &TextonRoutes::fallback);
    m_http.Get(R"(/v1/mixes/([^/]+))", call(m_mix_routes.get(), &MixRoutes::get));
    m_http.Get(R"(/v1/mixes/(.*))", &MixRoutes::fallback);
    m_http.Get(R"(/v1/splats/([^/]+))", call(m_splat_routes.get(), &SplatRoutes::get));
    m_http.Get(R"(/v1/splats/(.*))", &SplatRoutes::fallback);
    OpsRoutes* o = m_ops_routes.get();
    m_http.Get("/healthz", &OpsRoutes::healthz);
    m_http.Get("/readyz", call(o, &OpsRoutes::readyz));
    m_http.Get("/metrics", call(o, &OpsRoutes::metrics));
    m_http.Get("/v1/openapi.yaml", &OpsRoutes::openapi);
    m_http.Get("/", call(o, &OpsRoutes::page));
    m_http.Get(R"(/static/(.+))", call(o, &OpsRoutes::static_file));
}

} // namespace textond::http
