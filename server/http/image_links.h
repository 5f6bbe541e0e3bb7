#pragma once
// How image URLs are read and written: a URL's signature or preset checked into the query it is
// served with (api/README.md "Signed URLs and presets"), links signed for TileJSON and reports,
// the Cache-Control a signed URL's exp allows, whom a render is counted against and its rate
// (--render-rate), and the base URL of absolute links (--public-url or the Host header).
#include "api/requests.h"
#include "server/app/metrics.h"
#include "server/http/config.h"
#include "server/http/imports.h"
#include "server/http/rate_limiter.h"

#include <httplib.h>

#include <optional>
#include <string>
#include <string_view>

namespace textond::http {

class ImageLinks {
public:
    // `port`: the bound port, for absolute URLs when no --public-url is set.
    ImageLinks(const ServeConfig& config, Metrics& metrics, const int& port);

    // Cache-Control of an image: immutable, or until a signed URL's exp.
    std::string cache_control_for(const httplib::Request& req) const;
    // Takes a render from the client's rate (--render-rate); false, 429 sent, when it is spent.
    bool within_rate(const httplib::Request& req, httplib::Response& res);
    // Whom a render is counted against: the --api-key's holder, else the client's address.
    std::string rate_client(const httplib::Request& req) const;
    // The query an image is served with (api/README.md "Signed URLs and presets"): the request's,
    // its signature checked and sig and exp dropped, or the fields of the preset it names. Nothing,
    // the error sent, when refused. `format`: the URL's extension ("" when negotiated).
    std::optional<api::Query> served_query(const httplib::Request& req, httplib::Response& res,
                                           std::string_view format) const;
    // `path_and_query` as this server's clients must ask for it: signed when URLs are, with the
    // request's exp.
    std::string signed_link(const httplib::Request& req, const std::string& path_and_query) const;
    // Scheme and host of absolute links: --public-url, else the request's Host when it is a sane
    // host[:port], else the bound address.
    std::string base_url(const httplib::Request& req) const;

private:
    const ServeConfig& m_config;
    Metrics& m_metrics;
    const int& m_port;
    RateLimiter m_limiter; // renders per client (--render-rate)
};

} // namespace textond::http
