#include "server/http/connection.h"

#include "server/http/errors.h"
#include "server/http/request_context.h"
#include "server/http/responses.h"

#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <thread>

namespace textond::http {

namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

thread_local ConnectionStream* t_connection = nullptr;

// Lingering close: the client may still be sending the body we did not read; closing now would
// answer it with a reset, and a reset discards our answer in its buffers. Half-close, then
// discard what comes for a short while.
void linger(int sock) {
    ::shutdown(sock, SHUT_WR);
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    std::size_t drained = 0;
    char scratch[16384];
    while (drained < (std::size_t{64} << 20)) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            end - std::chrono::steady_clock::now());
        pollfd p{sock, POLLIN, 0};
        if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) <= 0) break;
        const ssize_t n = ::recv(sock, scratch, sizeof scratch, 0);
        if (n <= 0) break;
        drained += static_cast<std::size_t>(n);
    }
}

void address_of(int sock, bool peer, std::string& ip, int& port) {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    const int rc = peer ? ::getpeername(sock, reinterpret_cast<sockaddr*>(&addr), &len)
                        : ::getsockname(sock, reinterpret_cast<sockaddr*>(&addr), &len);
    if (rc != 0) return;
    char host[NI_MAXHOST], serv[NI_MAXSERV];
    if (::getnameinfo(reinterpret_cast<sockaddr*>(&addr), len, host, sizeof host, serv, sizeof serv,
                      NI_NUMERICHOST | NI_NUMERICSERV) != 0)
        return;
    ip = host;
    port = static_cast<int>(std::strtol(serv, nullptr, 10)); // numeric (NI_NUMERICSERV)
}

} // namespace

ConnectionStream::ConnectionStream(int sock, const ConnectionLimits& limits)
    : m_sock(sock), m_limits(limits) {}

bool ConnectionStream::wait(short events, milliseconds timeout) const {
    pollfd p{m_sock, events, 0};
    const auto end = Clock::now() + timeout;
    for (;;) {
        const auto left = std::chrono::duration_cast<milliseconds>(end - Clock::now()).count();
        const int rc = ::poll(&p, 1, static_cast<int>(std::max<long long>(0, left)));
        if (rc > 0) return (p.revents & (events | POLLHUP | POLLERR)) != 0;
        if (rc == 0) return false;
        if (errno != EINTR) return false;
    }
}

milliseconds ConnectionStream::read_wait() const {
    if (m_phase == Phase::idle) return m_limits.read_timeout;
    const auto left = std::chrono::duration_cast<milliseconds>(m_deadline - Clock::now());
    return std::max(milliseconds(0), std::min(left, m_limits.read_timeout));
}

bool ConnectionStream::is_readable() const {
    return m_off < m_len || wait(POLLIN, read_wait());
}

bool ConnectionStream::is_writable() const {
    return m_failure == Failure::none && wait(POLLOUT, m_limits.write_timeout);
}

ssize_t ConnectionStream::read(char* ptr, size_t size) {
    if (m_failure != Failure::none || size == 0) return -1;
    // Everything a phase reads counts against its budget, buffered bytes included.
    const std::size_t budget = m_phase == Phase::head   ? m_limits.max_header_bytes
                               : m_phase == Phase::body ? m_limits.max_body_bytes
                                                        : static_cast<std::size_t>(-1);
    if (m_phase_bytes >= budget) {
        m_failure = m_phase == Phase::head ? Failure::head_too_large : Failure::body_too_large;
        return -1;
    }
    size = std::min(size, budget - m_phase_bytes);
    // The phase's deadline holds however the bytes trickle in (one every second never lets a
    // wait time out) and whether or not they are buffered already.
    const auto timed_out = [this] {
        if (m_phase == Phase::idle || Clock::now() < m_deadline) return false;
        m_failure = m_phase == Phase::head ? Failure::head_timeout : Failure::body_timeout;
        return true;
    };
    if (timed_out()) return -1;
    if (m_off == m_len) {
        if (!wait(POLLIN, read_wait())) {
            // Within a request, a wait that ran out is a timeout whichever limit ended it.
            if (m_phase != Phase::idle)
                m_failure = m_phase == Phase::head ? Failure::head_timeout : Failure::body_timeout;
            return -1;
        }
        ssize_t n;
        do {
            n = ::recv(m_sock, m_buf.data(), m_buf.size(), 0);
        } while (n < 0 && errno == EINTR);
        if (n <= 0) return -1;
        m_off = 0;
        m_len = static_cast<std::size_t>(n);
    }
    const std::size_t n = std::min(size, m_len - m_off);
    if (m_phase == Phase::body && m_chunked && !check_chunked(m_buf.data() + m_off, n)) {
        m_failure = Failure::bad_chunk;
        return -1;
    }
    if (m_phase == Phase::head && !check_head(m_buf.data() + m_off, n)) {
        m_failure = Failure::bad_head;
        return -1;
    }
    std::memcpy(ptr, m_buf.data() + m_off, n);
    m_off += n;
    m_phase_bytes += n;
    return static_cast<ssize_t>(n);
}

ssize_t ConnectionStream::write(const char* ptr, size_t size) {
    // After a limit tripped, the library's own answer (a 400 for a head it could not finish)
    // is swallowed; the connection loop sends the precise one (431, 408, 413).
    if (m_failure != Failure::none) return -1;
    if (!wait(POLLOUT, m_limits.write_timeout)) {
        m_write_failed = true;
        return -1;
    }
    ssize_t n;
    do {
        n = ::send(m_sock, ptr, size, MSG_NOSIGNAL);
    } while (n < 0 && errno == EINTR);
    if (n > 0)
        m_written += static_cast<std::size_t>(n);
    else
        m_write_failed = true;
    return n;
}

void ConnectionStream::get_remote_ip_and_port(std::string& ip, int& port) const {
    address_of(m_sock, true, ip, port);
}

void ConnectionStream::get_local_ip_and_port(std::string& ip, int& port) const {
    address_of(m_sock, false, ip, port);
}

bool ConnectionStream::chunk_line_byte(char c) {
    const auto hex = [](char h) {
        return (h >= '0' && h <= '9') || (h >= 'a' && h <= 'f') || (h >= 'A' && h <= 'F');
    };
    switch (m_chunk) {
    case Chunk::size:
        if (hex(c) && m_size_digits < 15) {
            const int d = c <= '9' ? c - '0' : (c | 0x20) - 'a' + 10;
            m_chunk_left = m_chunk_left * 16 + static_cast<std::uint64_t>(d);
            ++m_size_digits;
        } else if (m_size_digits > 0 && (c == ';' || c == ' ' || c == '\t')) {
            m_chunk = Chunk::ext;
        } else if (m_size_digits > 0 && c == '\r') {
            m_chunk = Chunk::size_lf;
        } else {
            return false;
        }
        return true;
    case Chunk::ext:
        if (c == '\r') m_chunk = Chunk::size_lf;
        return c != '\n';
    case Chunk::size_lf:
        if (c != '\n') return false;
        m_chunk = m_chunk_left == 0 ? Chunk::trailer : Chunk::data;
        m_line_empty = true;
        return true;
    default:
        return false;
    }
}

bool ConnectionStream::chunk_tail_byte(char c) {
    switch (m_chunk) {
    case Chunk::data_cr:
        m_chunk = Chunk::data_lf;
        return c == '\r';
    case Chunk::data_lf:
        m_chunk = Chunk::size;
        m_size_digits = 0;
        return c == '\n';
    case Chunk::trailer:
        if (c == '\n') return false;
        if (c == '\r')
            m_chunk = m_line_empty ? Chunk::last_lf : Chunk::trailer_lf;
        else
            m_line_empty = false;
        return true;
    case Chunk::trailer_lf:
        m_chunk = Chunk::trailer;
        m_line_empty = true;
        return c == '\n';
    case Chunk::last_lf:
        m_chunk = Chunk::done;
        return c == '\n';
    default: // done: past the body's end, where the library never reads
        return false;
    }
}

bool ConnectionStream::head_byte(char c) {
    const auto token = [](char t) {
        return std::isalnum(static_cast<unsigned char>(t)) ||
               std::strchr("!#$%&'*+-.^_`|~", t) != nullptr;
    };
    if (c == '\0') return false;
    switch (m_head) {
    case Head::request:
    case Head::value:
        if (c == '\r') {
            m_after_cr = Head::line_start;
            m_head = Head::cr;
        } else if (c == '\n') {
            m_head = Head::line_start;
        } else if (c == '%' && m_framing_header) {
            return false;
        }
        return true;
    case Head::cr:
    case Head::end_cr:
        if (c != '\n') return false; // a bare CR
        m_head = m_head == Head::end_cr ? Head::done : m_after_cr;
        return true;
    case Head::line_start:
        if (c == '\r' || c == '\n') {
            m_head = c == '\r' ? Head::end_cr : Head::done;
            return true;
        }
        if (!token(c)) return false; // a folded line, or a name that is no token
        m_name.assign(1, static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
        m_head = Head::name;
        return true;
    case Head::name:
        if (c == ':') {
            m_framing_header = m_name == "content-length" || m_name == "transfer-encoding";
            m_head = Head::value;
            return true;
        }
        if (!token(c)) return false; // whitespace before the colon, or no colon at all
        if (m_name.size() < 20)
            m_name += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        return true;
    default: // done: the library reads no further head bytes
        return true;
    }
}

bool ConnectionStream::check_head(const char* p, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i)
        if (!head_byte(p[i])) return false;
    return true;
}

bool ConnectionStream::check_chunked(const char* p, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
        if (m_chunk == Chunk::data) {
            const std::uint64_t take = std::min<std::uint64_t>(m_chunk_left, n - i);
            m_chunk_left -= take;
            i += static_cast<std::size_t>(take) - 1;
            if (m_chunk_left == 0) m_chunk = Chunk::data_cr;
            continue;
        }
        const bool line =
            m_chunk == Chunk::size || m_chunk == Chunk::ext || m_chunk == Chunk::size_lf;
        if (!(line ? chunk_line_byte(p[i]) : chunk_tail_byte(p[i]))) return false;
    }
    return true;
}

void ConnectionStream::expect_body(std::uint64_t length, bool chunked) {
    m_expected = chunked ? 0 : length;
    m_chunked = chunked;
}

bool ConnectionStream::body_complete() const {
    return m_chunked ? m_chunk == Chunk::done : m_phase_bytes >= m_expected;
}

bool ConnectionStream::next_request(milliseconds timeout, const std::function<bool()>& stop,
                                    const std::function<int()>& crowd) {
    const bool fresh = m_requests++ == 0;
    const auto queued = current_task_queued_at();
    // Not shed before: a new connection's first request, or the next request of a client that
    // has just had its answer (wrk and games send it at once; closing in that instant was a
    // read error on their side, 5 in 1,900 requests at 256 connections).
    const auto grace_end =
        fresh ? (queued == Clock::time_point{} ? Clock::now() : queued) + kNewConnectionGrace
              : Clock::now() + kNextRequestGrace;
    m_phase = Phase::idle;
    m_phase_bytes = 0;
    m_expected = 0;
    m_written = 0;
    m_write_failed = false;
    m_chunked = false;
    m_chunk = Chunk::size;
    m_chunk_left = 0;
    m_size_digits = 0;
    m_head = Head::request;
    m_framing_header = false;
    if (m_off == m_len) {
        // In short waits, so that a stopping server does not wait out every idle connection.
        const auto end = Clock::now() + timeout;
        for (;;) {
            if (stop()) return false;
            const auto left = std::chrono::duration_cast<milliseconds>(end - Clock::now());
            if (left <= milliseconds(0)) return false;
            if (crowd && crowd() > 0 && Clock::now() >= grace_end) {
                if (wait(POLLIN, milliseconds(0))) break; // a request is already here
                return false;
            }
            if (wait(POLLIN, std::min(left, milliseconds(crowd ? 50 : 250)))) break;
        }
        if (stop()) return false;
    }
    m_phase = Phase::head;
    m_deadline = Clock::now() + m_limits.header_timeout;
    return true;
}

void ConnectionStream::begin_body() {
    m_phase = Phase::body;
    m_phase_bytes = 0;
    m_deadline = Clock::now() + m_limits.body_timeout;
}

bool ConnectionStream::client_gone() const {
    pollfd p{m_sock, POLLRDHUP, 0};
    if (::poll(&p, 1, 0) <= 0) return false;
    return (p.revents & (POLLRDHUP | POLLHUP | POLLERR | POLLNVAL)) != 0;
}

ConnectionStream* current_connection() {
    return t_connection;
}

ConnectionScope::ConnectionScope(ConnectionStream* c) {
    t_connection = c;
}

ConnectionScope::~ConnectionScope() {
    t_connection = nullptr;
}

std::pair<int, std::size_t> send_connection_error(ConnectionStream& strm, const char* code,
                                                  const char* message, const std::string& id) {
    const int status = http_status(code);
    const char* reason = status == 408   ? "Request Timeout"
                         : status == 413 ? "Content Too Large"
                         : status == 431 ? "Request Header Fields Too Large"
                                         : "Bad Request";
    const std::string body = std::string(R"({"error": {"code": ")") + code + R"(", "message": ")" +
                             message + R"("}, "request_id": ")" + id + "\"}";
    std::string head =
        "HTTP/1.1 " + std::to_string(status) + " " + reason +
        "\r\nContent-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) +
        "\r\nCache-Control: no-store\r\nX-Request-Id: " + id + "\r\nConnection: close\r\n";
    for (const auto& [name, value] : security_headers())
        head += std::string(name) + ": " + value + "\r\n";
    head += "\r\n";
    const std::string all = head + body;
    // Straight to the socket, once, without waiting: the client is misbehaving already.
    const ssize_t n = ::send(strm.socket(), all.data(), all.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    return {status, n > 0 ? static_cast<std::size_t>(n) : 0};
}

void HttpServer::answer_failure(ConnectionStream& strm) {
    const auto canned = [&](const char* code, const char* message) {
        const std::string id = fresh_request_id();
        const auto [status, bytes] = send_connection_error(strm, code, message, id);
        if (on_connection_error) on_connection_error(status, bytes, id);
    };
    switch (strm.failure()) {
    case ConnectionStream::Failure::none:
        break;
    case ConnectionStream::Failure::head_too_large:
        canned("header_too_large", "request line and headers are over the server's limit");
        break;
    case ConnectionStream::Failure::head_timeout:
        canned("header_timeout", "request line and headers did not arrive in time");
        break;
    case ConnectionStream::Failure::body_too_large:
        canned("payload_too_large", "request body is over the upload limit");
        break;
    case ConnectionStream::Failure::body_timeout:
        canned("body_timeout", "request body did not arrive in time");
        break;
    case ConnectionStream::Failure::bad_head:
        canned("bad_request", "malformed request head (each header line is NAME: VALUE, with no "
                              "folding, bare CR or NUL, and no % in Content-Length or "
                              "Transfer-Encoding)");
        break;
    case ConnectionStream::Failure::bad_chunk:
        canned("bad_framing", "malformed chunked body (each chunk's data must end in CRLF; "
                              "lines end in CRLF)");
        break;
    }
}

bool HttpServer::process_and_close_socket(socket_t sock) {
    ConnectionStream strm(sock, limits);
    ConnectionScope scope(&strm);
    const auto stopping = [this] { return !m_standalone && svr_sock_ == INVALID_SOCKET; };
    bool ok = false;
    for (int left = limits.keep_alive_max; left > 0; --left) {
        if (!strm.next_request(limits.keep_alive_timeout, stopping, crowd)) break;
        bool closed = false;
        ok = process_request(strm, left == 1, closed, nullptr);
        answer_failure(strm);
        // A body the route did not read to its end is still on the wire, and its bytes are no
        // request: they must never be parsed as the next one (request smuggling).
        if (!strm.body_complete()) strm.close_after_response();
        if (!ok || closed || strm.must_close() || strm.failure() != ConnectionStream::Failure::none)
            break;
    }
    if (strm.must_close() || strm.failure() != ConnectionStream::Failure::none) linger(sock);
    ::shutdown(sock, SHUT_RDWR);
    ::close(sock);
    return ok;
}

namespace {
thread_local std::chrono::steady_clock::time_point t_task_queued_at{};
} // namespace

std::chrono::steady_clock::time_point current_task_queued_at() {
    return t_task_queued_at;
}

ElasticThreadPool::ElasticThreadPool(std::size_t core, std::size_t max)
    : m_core(std::max<std::size_t>(1, core)), m_max(std::max(max, m_core)) {
    std::lock_guard lock(m_mutex);
    for (std::size_t i = 0; i < m_core; ++i) {
        ++m_threads;
        std::thread([this] { worker(true); }).detach();
    }
}

ElasticThreadPool::~ElasticThreadPool() {
    shutdown();
}

void ElasticThreadPool::start_thread_locked() {
    ++m_threads;
    std::thread([this] { worker(false); }).detach();
}

void ElasticThreadPool::enqueue(std::function<void()> fn) {
    std::lock_guard lock(m_mutex);
    m_queue.emplace_back(std::move(fn), std::chrono::steady_clock::now());
    m_waiting.store(m_queue.size(), std::memory_order_relaxed);
    if (m_idle < m_queue.size() && m_threads < m_max) start_thread_locked();
    m_work.notify_one();
}

void ElasticThreadPool::worker(bool core) {
    std::unique_lock lock(m_mutex);
    for (;;) {
        ++m_idle;
        const bool woke = m_work.wait_for(lock, std::chrono::seconds(10),
                                          [this] { return m_shutdown || !m_queue.empty(); });
        --m_idle;
        if (m_queue.empty()) {
            if (m_shutdown || (!woke && !core)) break;
            continue;
        }
        std::function<void()> fn = std::move(m_queue.front().first);
        t_task_queued_at = m_queue.front().second;
        m_queue.pop_front();
        m_waiting.store(m_queue.size(), std::memory_order_relaxed);
        m_busy.fetch_add(1, std::memory_order_relaxed);
        lock.unlock();
        fn();
        lock.lock();
        m_busy.fetch_sub(1, std::memory_order_relaxed);
    }
    --m_threads;
    m_exited.notify_all();
}

void ElasticThreadPool::shutdown() {
    std::unique_lock lock(m_mutex);
    m_shutdown = true;
    m_work.notify_all();
    m_exited.wait(lock, [this] { return m_threads == 0; });
}

} // namespace textond::http
