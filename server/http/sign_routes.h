#pragma once
// POST /v1/sign (api/sign_request.h): the server signs image URLs for holders of its --api-key,
// so a client that must never hold --url-signing-key (the page, a browser) can still hand them
// out. Without a signing key the URLs come back as they are ("signed": false); with one but no
// --api-key nobody may sign (403 signing_unavailable), or anyone could.
#include "server/http/config.h"
#include "server/http/gate.h"
#include "server/http/imports.h"

#include <httplib.h>

namespace textond::http {

class SignRoutes {
public:
    SignRoutes(const ServeConfig& config, Gate& gate);
    void sign(const httplib::Request& req, httplib::Response& res,
              const httplib::ContentReader& reader);

private:
    const ServeConfig& m_config;
    Gate& m_gate;
};

} // namespace textond::http
