#pragma once
#include "server/http/imports.h"
// One client connection, with the limits cpp-httplib 0.11 (Debian 12) does not have. The library
// reads a request line and headers of any length and count, at any pace, and its per-request
// socket stream forgets bytes it had already read (pipelined requests were dropped). Its
// protected Server::process_request takes any httplib::Stream, so the connection loop is ours
// (HttpServer::process_and_close_socket) and the stream below enforces, per request:
//   - the request head (request line and headers): at most max_header_bytes, all of it within
//     header_timeout from its first byte (slow-header clients get 408 and are dropped);
//   - the body: at most max_body_bytes on the wire (chunked framing included) within
//     body_timeout; the routes count the decoded bytes exactly (server/http/request_body.h).
// Parsing stays the library's: this layer only counts, times and buffers bytes.
#include <httplib.h>

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <utility>

namespace textond::http {

struct ConnectionLimits {
    std::size_t max_header_bytes = 64 * 1024;
    std::chrono::milliseconds header_timeout{10'000};
    std::size_t max_body_bytes = std::size_t{33} << 20;
    std::chrono::milliseconds body_timeout{120'000};
    std::chrono::milliseconds read_timeout{30'000};  // any one wait for bytes
    std::chrono::milliseconds write_timeout{30'000}; // any one wait for the client to take bytes
    std::chrono::milliseconds keep_alive_timeout{5'000};
    int keep_alive_max = 1000;
};

class ConnectionStream final : public httplib::Stream {
public:
    enum class Phase { idle, head, body };
    enum class Failure {
        none,
        head_too_large,
        head_timeout,
        body_too_large,
        body_timeout,
        bad_chunk,
        bad_head
    };

    ConnectionStream(int sock, const ConnectionLimits& limits);

    bool is_readable() const override;
    bool is_writable() const override;
    ssize_t read(char* ptr, size_t size) override;
    ssize_t write(const char* ptr, size_t size) override;
    void get_remote_ip_and_port(std::string& ip, int& port) const override;
    void get_local_ip_and_port(std::string& ip, int& port) const override;
    int socket() const override { return m_sock; }

    // Waits up to `timeout` for the first byte of the next request (buffered bytes of a
    // pipelined one count), giving up early when `stop` turns true, or when the threads run
    // short (`crowd`, ElasticThreadPool::crowd) while nothing has come: an idle connection gives
    // its thread up first. A new connection has kNewConnectionGrace from its accept (time spent
    // waiting for a thread included) for its first bytes, a kept-alive one kNextRequestGrace
    // after its last answer. Then the head phase starts.
    bool next_request(std::chrono::milliseconds timeout, const std::function<bool()>& stop,
                      const std::function<int()>& crowd = {});
    static constexpr std::chrono::milliseconds kNewConnectionGrace{100};
    static constexpr std::chrono::milliseconds kNextRequestGrace{20}; // after an answer
    // The head has been parsed (pre-routing): from here on bytes count against the body.
    void begin_body();
    // What the head said of the body: `length` bytes, or chunked. The connection closes after
    // the response unless the route read the body to its end (a body left unread is not a
    // request), and chunked framing is checked as it passes (cpp-httplib 0.11 accepts chunk
    // data not followed by CRLF and bare-LF size lines, and stops early on garbage).
    void expect_body(std::uint64_t length, bool chunked);
    // The body the head announced has been read to its last byte (true when there was none).
    bool body_complete() const;
    // The client closed its side or reset the connection (it will never read the answer).
    bool client_gone() const;
    // Ask for the connection to be closed after the response being written (the request's body
    // was not read to its end, so the bytes that follow are not a request).
    void close_after_response() { m_close = true; }
    bool must_close() const { return m_close; }
    Failure failure() const { return m_failure; }
    // Bytes of this request's answer the client took, and whether it stopped taking them.
    std::size_t written() const { return m_written; }
    bool write_failed() const { return m_write_failed; }
    const ConnectionLimits& limits() const { return m_limits; }

private:
    bool wait(short events, std::chrono::milliseconds timeout) const;
    std::chrono::milliseconds read_wait() const; // the shorter of read timeout and phase deadline

    int m_sock;
    const ConnectionLimits& m_limits;
    std::array<char, 16 * 1024> m_buf{};
    std::size_t m_off = 0, m_len = 0;
    Phase m_phase = Phase::idle;
    std::size_t m_phase_bytes = 0;
    std::chrono::steady_clock::time_point m_deadline{};
    // Chunked framing, checked byte by byte as the library reads it (RFC 9112 section 7.1).
    enum class Chunk {
        size,
        ext,
        size_lf,
        data,
        data_cr,
        data_lf,
        trailer,
        trailer_lf,
        last_lf,
        done
    };
    bool check_chunked(const char* p, std::size_t n);
    // The head's lines, checked byte by byte as the library reads them (RFC 9112 section 5): the
    // library drops a line without a colon, keeps `Content-Length : 5` under another name,
    // unfolds nothing and URL-decodes values, so each could hide a body from the framing checks
    // while a proxy reads it: a header line is a token, a colon and a value without NUL or bare
    // CR; no folded lines; no `%` in Content-Length or Transfer-Encoding.
    enum class Head { request, line_start, name, value, cr, end_cr, done };
    bool check_head(const char* p, std::size_t n);
    bool head_byte(char c);
    Head m_head = Head::request;
    Head m_after_cr = Head::line_start;
    std::string m_name; // the header's name, lower case, while it is read (first 20 bytes)
    bool m_framing_header = false;
    bool chunk_line_byte(char c); // a size line
    bool chunk_tail_byte(char c); // after a chunk's data, the trailers and the end
    std::uint64_t m_expected = 0; // body bytes announced by Content-Length
    bool m_chunked = false;
    Chunk m_chunk = Chunk::size;
    std::uint64_t m_chunk_left = 0;
    int m_size_digits = 0;
    bool m_line_empty = true;
    Failure m_failure = Failure::none;
    bool m_close = false;
    std::size_t m_written = 0;
    bool m_write_failed = false;
    int m_requests = 0; // begun on this connection
};

// The connection the calling thread is serving (null outside a request): the routes use it to
// read bodies with limits, to notice a client that left, and to close after a partial read.
ConnectionStream* current_connection();

class ConnectionScope {
public:
    explicit ConnectionScope(ConnectionStream* c);
    ~ConnectionScope();
    ConnectionScope(const ConnectionScope&) = delete;
    ConnectionScope& operator=(const ConnectionScope&) = delete;
};

// A canned answer for a request the library could not be given (head too large or too slow):
// status line, a JSON body with the request id and Connection: close, written straight to the
// socket. Returns its status and the bytes the socket took.
std::pair<int, std::size_t> send_connection_error(ConnectionStream& strm, const char* code,
                                                  const char* message, const std::string& id);

// Connection threads: `core` kept, more started on demand up to `max` so that clients that hold
// a thread without sending (slowloris) do not stop new clients from being served; extra threads
// end after a minute idle. cpp-httplib's ThreadPool is fixed-size: 128 slow clients took every
// one of its threads.
//
// Idle connections (keep-alive, or open and silent) hold a thread each while they wait for a
// request: 1,100 of them, reopened as they closed, took every thread and kept /healthz waiting
// 4-5 s. When the pool is crowded (a connection is waiting for a thread, or three quarters of
// `max` are busy) an idle connection is closed instead (crowd(); ConnectionStream::next_request
// says when); one with a request in flight never is. Extra threads end after 10 s idle.
// When the task running on this thread was queued (accepted, for a connection); epoch if none.
std::chrono::steady_clock::time_point current_task_queued_at();

class ElasticThreadPool final : public httplib::TaskQueue {
public:
    ElasticThreadPool(std::size_t core, std::size_t max);
    ~ElasticThreadPool() override;
    void enqueue(std::function<void()> fn) override;
    void shutdown() override;
    // Whether idle connections should give their threads up now: 2 when connections wait for a
    // thread, 1 when three quarters of the threads are busy, else 0.
    int crowd() const {
        if (m_waiting.load(std::memory_order_relaxed) > 0) return 2;
        return m_busy.load(std::memory_order_relaxed) * 4 >= m_max * 3 ? 1 : 0;
    }

private:
    void start_thread_locked();
    void worker(bool core);

    const std::size_t m_core, m_max;
    std::mutex m_mutex;
    std::condition_variable m_work;
    std::condition_variable m_exited;
    std::deque<std::pair<std::function<void()>, std::chrono::steady_clock::time_point>> m_queue;
    std::size_t m_threads = 0, m_idle = 0;
    std::atomic<std::size_t> m_waiting{0}, m_busy{0}; // queued connections, threads serving one
    bool m_shutdown = false;
};

// cpp-httplib's server with our connection loop (above) and, because cpp-httplib 0.11 listens
// with a backlog of 5 (a burst of 64 clients overflowed it and the kernel dropped SYNs), access
// to its listening socket: Linux lets listen() be called again on it to enlarge the backlog.
class HttpServer : public httplib::Server {
public:
    socket_t listening_socket() const { return svr_sock_; }
    ConnectionLimits limits; // set before listening
    // Says when an idle connection should close to free its thread (the pool's crowd()).
    std::function<int()> crowd;
    // The access log and metrics of a request answered by the connection loop itself (408, 413,
    // 431, a broken chunked body): status, bytes sent, request id.
    std::function<void(int, std::size_t, const std::string&)> on_connection_error;
    // Serves one connection on the calling thread without listening (the framing fuzzer).
    bool serve_connection(socket_t sock) {
        m_standalone = true;
        return process_and_close_socket(sock);
    }

private:
    bool m_standalone = false; // not listening: no stop to wait for
    bool process_and_close_socket(socket_t sock) override;
    // The answer of a request a limit cut short (431, 408, 413, a broken chunk), if one was.
    void answer_failure(ConnectionStream& strm);
};

} // namespace textond::http
