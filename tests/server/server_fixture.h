#pragma once
// A real textond HTTP service for tests: in-process on 127.0.0.1 with a free port and a fresh
// data directory (TestServer), or the `textond serve` binary in a child process (ServerProcess,
// for kill -9 and signals). Both are spoken to over real HTTP with cpp-httplib's client.
#include "core/image.h"
#include "server/http/config.h"
#include "server/http/textond_server.h"

#include <httplib.h>

#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace textond::test {

class TestServer {
public:
    explicit TestServer(http::ServeConfig config = default_config());
    ~TestServer();
    static http::ServeConfig default_config(); // port 0, CPU backend, a fresh data directory

    httplib::Client client() const;
    http::TextondServer& service() { return *m_service; }
    const std::string& data_dir() const { return m_config.data_dir; }
    int port() const { return m_port; }

private:
    http::ServeConfig m_config;
    std::unique_ptr<http::TextondServer> m_service;
    std::thread m_thread;
    int m_port = 0;
};

class ServerProcess {
public:
    // `file_size_limit` (bytes, 0 = none) caps every file the server writes (RLIMIT_FSIZE, with
    // SIGXFSZ ignored so writes fail with EFBIG): a full disk without root or a mount.
    ServerProcess(const std::string& data_dir, const std::vector<std::string>& extra_args = {},
                  unsigned long file_size_limit = 0);
    ~ServerProcess();
    httplib::Client client() const;
    int pid() const { return m_pid; }
    int port() const { return m_port; }
    void kill_hard();              // SIGKILL, no chance to clean up
    int terminate(int timeout_ms); // SIGTERM, returns the exit status (or -1 on timeout)

private:
    int m_pid = -1;
    int m_port = 0;
};

// A real redis-server (Debian's) on a free loopback port, persisting to `dir` with an fsync per
// write, so stop() and start() are a Redis outage that loses nothing.
class RedisProcess {
public:
    explicit RedisProcess(const std::string& dir);
    ~RedisProcess();
    void start();
    void stop(); // SIGTERM, waits for the exit
    int port() const { return m_port; }
    std::string url() const { return "redis://127.0.0.1:" + std::to_string(m_port); }
    // redis-cli with these arguments (and `input` on stdin for -x); returns its output.
    std::string cli(const std::vector<std::string>& args, const std::string& input = "") const;

private:
    std::string m_dir;
    int m_port = 0;
    int m_pid = -1;
};

std::string read_file(const std::string& path);
std::string fresh_dir(const std::string& name);
// Decodes PNG/EXR response bytes (any format the server writes).
core::Image decode(const std::string& bytes);
// Id of an uploaded exemplar; fails the test unless the status is 200 or 201.
std::string upload(httplib::Client& c, const std::string& exemplar_name,
                   const std::string& query = "", int* status = nullptr);

} // namespace textond::test
