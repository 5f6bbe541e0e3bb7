// `textond sign URL`: the URL with exp and sig added, as a server started with the same
// --url-signing-key checks them (server/app/url_signing.h; api/README.md "Signed URLs and
// presets").
#include "server/app/url_signing.h"
#include "server/cli/args.h"
#include "server/cli/commands.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>

namespace textond::cli {

namespace {
const char* kHelp = R"(usage: textond sign URL [--key KEY] [--expires-in S]

Prints URL (a path with its query, or an absolute URL) signed for a server run with
--url-signing-key KEY: an HMAC-SHA256 of the path (a tile's: its layer, {z}/{x}/{y}) and the
sorted query in sig, after exp when --expires-in is given. A tile layer's signature serves all
of its tiles.

  --key KEY          the server's --url-signing-key          [TEXTOND_URL_SIGNING_KEY]
  --expires-in S     the URL stops working S seconds from now  [never]
)";
} // namespace

int sign_command(const Argv& argv) {
    auto a = parse_args(argv, {"--key", "--expires-in"}, {"--help"});
    if (!a) return fail(2, a.error().message);
    if (a.value().flags.count("--help")) {
        std::fputs(kHelp, stdout);
        return 0;
    }
    if (a.value().positional.size() != 1) return fail(2, "sign takes one URL (sign --help)");
    const char* env = std::getenv("TEXTOND_URL_SIGNING_KEY");
    const std::string key = a.value().get("--key", env ? env : "");
    if (key.empty()) return fail(2, "sign: give --key or TEXTOND_URL_SIGNING_KEY");
    auto seconds = a.value().get_int("--expires-in", 0, 1, 10LL * 365 * 86400);
    if (!seconds) return fail(2, seconds.error().message);
    std::int64_t exp = 0;
    if (seconds.value() > 0)
        exp = std::chrono::duration_cast<std::chrono::seconds>(
                  std::chrono::system_clock::now().time_since_epoch())
                  .count() +
              seconds.value();
    auto url = app::sign_url(key, a.value().positional[0], exp);
    if (!url) return fail(2, "sign: " + url.error().message);
    std::puts(url.value().c_str());
    return 0;
}

} // namespace textond::cli
