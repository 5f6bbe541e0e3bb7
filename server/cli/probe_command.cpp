// `textond probe URL`: GET a URL and exit 0 on a 2xx answer. The image's HEALTHCHECK, which
// needs no curl in a slim image.
#include "server/cli/commands.h"

#include <httplib.h>

#include <cstdio>
#include <cstdlib>
#include <regex>
#include <string>

namespace textond::cli {

int probe_command(const Argv& args) {
    if (args.size() == 1 && (args[0] == "--help" || args[0] == "-h")) {
        std::puts("usage: textond probe [URL]\n\nGETs URL (default "
                  "http://127.0.0.1:$TEXTOND_PORT/healthz, port 8080 when unset: the port serve "
                  "listens on) with a 3 s timeout; exit 0 on 2xx, else 1.");
        return 0;
    }
    if (args.size() > 1) return fail(2, "probe takes one URL");
    // Without a URL: the port `serve` takes from the same environment, so an image's health
    // check follows TEXTOND_PORT.
    const char* env_port = std::getenv("TEXTOND_PORT");
    const std::string url =
        !args.empty()
            ? args[0]
            : "http://127.0.0.1:" + std::string(env_port && *env_port ? env_port : "8080") +
                  "/healthz";
    static const std::regex kUrl(R"(^http://([^/:]+|\[[0-9a-fA-F:]+\])(?::(\d{1,5}))?(/.*)?$)");
    std::smatch m;
    if (!std::regex_match(url, m, kUrl)) return fail(2, "probe: not an http:// URL: " + url);
    std::string host = m[1].str();
    if (host.front() == '[') host = host.substr(1, host.size() - 2);
    const int port = m[2].matched ? std::stoi(m[2].str()) : 80;
    if (port < 1 || port > 65535) return fail(2, "probe: bad port in " + url);
    httplib::Client c(host, port);
    c.set_connection_timeout(3, 0);
    c.set_read_timeout(3, 0);
    auto res = c.Get(m[3].matched ? m[3].str().c_str() : "/");
    if (!res) return fail(1, "probe: " + url + ": " + httplib::to_string(res.error()));
    if (res->status < 200 || res->status > 299)
        return fail(1, "probe: " + url + ": HTTP " + std::to_string(res->status));
    return 0;
}

} // namespace textond::cli
