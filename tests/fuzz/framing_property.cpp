// The framing property, checked by request_fuzzer: a stream of N complete requests
// gets at most N answers, exactly N when every request is well framed (fewer only when the
// connection closed), the answers in request order, and a request hidden in a body is never
// answered. The stream goes through the service's own connection loop (HttpServer,
// ConnectionStream) and framing checks (server/http/framing.h) over a socketpair; the routes
// are stand-ins that read bodies as the real ones do.
#include "tests/fuzz/framing_property.h"

#include "server/http/connection.h"
#include "server/http/framing.h"
#include "server/http/request_context.h"

#include <fuzzer/FuzzedDataProvider.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <string>
#include <vector>

namespace textond::test {

namespace {

constexpr const char* kHidden = "GET /hidden HTTP/1.1\r\nHost: x\r\n\r\n";
constexpr std::size_t kMaxBody = 4096;

struct Composed {
    std::string bytes;
    int requests = 0;   // complete requests at the top level
    int answerable = 0; // of them, those before and including the first Connection: close
    bool well_framed = true;
    bool ended = false; // a request whose length runs past the stream's end came last
};

std::vector<std::string>& answers() {
    static std::vector<std::string> a;
    return a;
}

std::string chunked(FuzzedDataProvider& in, const std::string& body) {
    std::string out;
    const bool upper = in.ConsumeBool();
    for (std::size_t pos = 0; pos < body.size();) {
        const std::size_t n =
            std::min(body.size() - pos, in.ConsumeIntegralInRange<std::size_t>(1, 64));
        char size[32];
        std::snprintf(size, sizeof size, upper ? "%zX" : "%zx", n);
        out += size;
        if (in.ConsumeBool()) out += ";ext=1";
        out += "\r\n" + body.substr(pos, n) + "\r\n";
        pos += n;
    }
    return out + "0\r\n\r\n";
}

// A chunked body with one defect the library used to accept or the stream could be misread by.
std::string broken_chunked(FuzzedDataProvider& in, const std::string& body) {
    const std::string data = body.empty() ? std::string("x") : body;
    char size[32];
    std::snprintf(size, sizeof size, "%zx", data.size());
    switch (in.ConsumeIntegralInRange(0, 4)) {
    case 0:
        return std::string(size) + "\r\n" + data + "XX0\r\n\r\n"; // no CRLF after the data
    case 1:
        return std::string(size) + "\n" + data + "\r\n0\r\n\r\n"; // bare LF size line
    case 2:
        return "g" + std::string(size) + "\r\n" + data + "\r\n0\r\n\r\n"; // not hex
    case 3:
        return std::string(size) + "\r\n" + data + "\r\n0\r\nX\r\n"; // no end of trailers
    default:
        return "+" + std::string(size) + "\r\n" + data + "\r\n0\r\n\r\n"; // signed size
    }
}

void add_request(FuzzedDataProvider& in, int index, Composed& s) {
    static const char* const kMethods[] = {"GET", "HEAD", "OPTIONS", "DELETE", "POST"};
    const std::string method = kMethods[in.ConsumeIntegralInRange(0, 4)];
    const bool post = method == "POST";
    std::string body =
        in.ConsumeBool() ? std::string(kHidden) : in.ConsumeRandomLengthString(kMaxBody / 8);
    if (in.ConsumeBool()) body += kHidden;
    const bool closes = in.ConsumeIntegralInRange(0, 7) == 0;
    std::string head = method + " /r" + std::to_string(index) + " HTTP/1.1\r\nHost: x\r\n";
    if (closes) head += "Connection: close\r\n";
    bool valid = true;
    std::string framed;
    switch (in.ConsumeIntegralInRange(0, 7)) {
    case 0: // no framing headers: no body
        body.clear();
        valid = !post; // a POST needs a length (411)
        break;
    case 1: // Content-Length, exact
        head += "Content-Length: " + std::to_string(body.size()) + "\r\n";
        valid = post || body.empty();
        framed = body;
        break;
    case 2:
        head += "Transfer-Encoding: chunked\r\n";
        valid = post;
        framed = chunked(in, body);
        break;
    case 3:
        head += "Transfer-Encoding: chunked\r\n";
        valid = false;
        framed = broken_chunked(in, body);
        break;
    case 4: { // a Content-Length that is not one decimal number
        // Each after "Content-Length": the library once ignored the last five (a name with a
        // space, no colon, a folded value, a bare CR, a URL-encoded value).
        static const char* const kForms[] = {
            ": +%zu",  ": %zu, %zu", ": 0x%zx",     ": %zu\r\nContent-Length: %zu",
            " : %zu",  " %zu",       ": 0\r\n %zu", "-X: 1\rContent-Length: %zu",
            ": %%3%zu"};
        char v[96];
        const int form = in.ConsumeIntegralInRange(0, 8);
        std::snprintf(v, sizeof v, kForms[form], form == 8 ? body.size() % 10 : body.size(),
                      body.size());
        head += std::string("Content-Length") + v + "\r\n";
        valid = false;
        framed = body;
        break;
    }
    case 5: // both
        head +=
            "Content-Length: " + std::to_string(body.size()) + "\r\nTransfer-Encoding: chunked\r\n";
        valid = false;
        framed = chunked(in, body);
        break;
    case 6: // a coding other than chunked
        head += in.ConsumeBool() ? "Transfer-Encoding: gzip\r\n"
                                 : "Transfer-Encoding: chunked, chunked\r\n";
        valid = false;
        framed = chunked(in, body);
        break;
    default: // a length past the end of the stream (followed by anything, the bytes it takes in
             // would be a body by the protocol's own reading, whatever requests they hold)
        head +=
            "Content-Length: " + std::to_string(body.size() + in.ConsumeIntegralInRange(1, 64)) +
            "\r\n";
        valid = false;
        framed = body;
        s.ended = true;
        break;
    }
    s.bytes += head + "\r\n" + framed;
    s.well_framed = s.well_framed && valid;
    ++s.requests;
    if (s.answerable == index) s.answerable = closes ? -(index + 1) : index + 1;
}

Composed compose(const std::uint8_t* data, std::size_t size) {
    FuzzedDataProvider in(data, size);
    Composed s;
    const int n = in.ConsumeIntegralInRange(1, 7);
    for (int i = 0; i < n && !s.ended && in.remaining_bytes() > 0; ++i) add_request(in, i, s);
    if (s.answerable < 0) s.answerable = -s.answerable; // a close stops the count there
    return s;
}

http::HttpServer& server() {
    static http::HttpServer* svr = [] {
        auto* s = new http::HttpServer;
        s->limits.header_timeout = std::chrono::milliseconds(500);
        s->limits.read_timeout = std::chrono::milliseconds(500);
        s->limits.keep_alive_timeout = std::chrono::milliseconds(200);
        s->limits.max_body_bytes = 64 * 1024;
        s->set_pre_routing_handler([](const httplib::Request& req, httplib::Response& res) {
            http::begin_request(req);
            if (auto e = http::frame_request(req, 100, kMaxBody * 2)) {
                res.status = 400;
                res.set_content(e->code, "text/plain");
                return httplib::Server::HandlerResponse::Handled;
            }
            if (req.method != "OPTIONS") return httplib::Server::HandlerResponse::Unhandled;
            res.status = 204;
            return httplib::Server::HandlerResponse::Handled;
        });
        const auto answer = [](const httplib::Request& req, httplib::Response& res) {
            res.set_content(req.path, "text/plain");
        };
        s->Get(R"(/r\d)", answer);
        s->Delete(R"(/r\d)", answer);
        s->Post(R"(/r\d)", [](const httplib::Request& req, httplib::Response& res,
                              const httplib::ContentReader& reader) {
            std::string body;
            const bool ok = reader([&](const char* d, std::size_t n) {
                body.append(d, n);
                return body.size() <= kMaxBody * 2;
            });
            if (!ok) {
                if (auto* c = http::current_connection()) c->close_after_response();
                res.status = 400;
                return;
            }
            res.set_content(req.path, "text/plain");
        });
        s->set_error_handler([](const httplib::Request&, httplib::Response& res) {
            http::close_after_library_error(res.status);
        });
        s->set_post_routing_handler(
            [](const httplib::Request&, httplib::Response& res) { http::announce_close(res); });
        // Answers that reached the wire: after a limit tripped, the library's own answer is
        // swallowed and the connection loop's canned one goes out instead.
        s->set_logger([](const httplib::Request& req, const httplib::Response&) {
            const http::ConnectionStream* c = http::current_connection();
            if (c && c->written() > 0) answers().push_back(req.path);
        });
        s->on_connection_error = [](int, std::size_t bytes, const std::string&) {
            if (bytes > 0) answers().push_back("(connection)");
        };
        return s;
    }();
    return *svr;
}

// What failed, the stream (escaped) and the answers, then a trap for libFuzzer.
[[noreturn]] void fail(const Composed& s, const std::string& what) {
    std::string shown;
    for (unsigned char c : s.bytes) {
        if (c == '\r')
            shown += "\\r";
        else if (c == '\n')
            shown += "\\n\n";
        else if (c < 32 || c > 126) {
            char hex[8];
            std::snprintf(hex, sizeof hex, "\\x%02x", c);
            shown += hex;
        } else
            shown += static_cast<char>(c);
    }
    std::fprintf(stderr, "framing: %s\n--- stream ---\n%s\n--- answers:", what.c_str(),
                 shown.c_str());
    for (const std::string& a : answers()) std::fprintf(stderr, " %s", a.c_str());
    std::fprintf(stderr, "\n");
    __builtin_trap();
}

} // namespace

void check_framing_property(const std::uint8_t* data, std::size_t size) {
    const Composed s = compose(data, size);
    if (s.requests == 0) return;
    int fds[2];
    if (::socketpair(AF_UNIX, SOCK_STREAM, 0, fds) != 0) return;
    const int buffer = 1 << 20;
    ::setsockopt(fds[0], SOL_SOCKET, SO_SNDBUF, &buffer, sizeof buffer);
    ::setsockopt(fds[1], SOL_SOCKET, SO_SNDBUF, &buffer, sizeof buffer);
    // The whole stream at once, then end of input: every read the server makes is answered.
    if (::send(fds[0], s.bytes.data(), s.bytes.size(), MSG_NOSIGNAL) !=
        static_cast<ssize_t>(s.bytes.size())) {
        ::close(fds[0]);
        ::close(fds[1]);
        return;
    }
    ::shutdown(fds[0], SHUT_WR);
    answers().clear();
    server().serve_connection(fds[1]); // closes fds[1]
    ::close(fds[0]);

    const auto& got = answers();
    const int n = static_cast<int>(got.size());
    if (n > s.answerable)
        fail(s, std::to_string(n) + " answers to " + std::to_string(s.answerable) + " requests");
    if (s.well_framed && n != s.answerable)
        fail(s, std::to_string(n) + " answers to " + std::to_string(s.answerable) +
                    " well-framed requests");
    // Answers come in request order, each to a request of the stream, none to a hidden one.
    int last = -1;
    for (const std::string& path : got) {
        if (path == "/hidden") fail(s, "a request hidden in a body was answered");
        if (path.size() == 3 && path.compare(0, 2, "/r") == 0) {
            const int i = path[2] - '0';
            if (i <= last) fail(s, "answers out of order");
            last = i;
        }
    }
}

} // namespace textond::test
