#include "tests/server/server_fixture.h"

#include "server/io/image_io.h"
#include "tests/support/test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <arpa/inet.h>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <netinet/in.h>
#include <sstream>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

namespace textond::test {

namespace fs = std::filesystem;

std::string read_file(const std::string& path) {
    auto bytes = io::read_file(path);
    if (!bytes) throw std::runtime_error(bytes.error().message);
    return std::move(bytes.value());
}

std::string fresh_dir(const std::string& name) {
    const std::string dir = temp_path(name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

core::Image decode(const std::string& bytes) {
    auto r = io::decode_image_memory(bytes);
    if (!r) throw std::runtime_error("cannot decode response: " + r.error().message);
    return std::move(r.value());
}

std::string upload(httplib::Client& c, const std::string& exemplar_name, const std::string& query,
                   int* status) {
    const std::string body = read_file(exemplar_path(exemplar_name));
    auto res = c.Post(("/v1/textons" + query).c_str(), body, "image/png");
    if (!res) {
        ADD_FAILURE() << "upload of " << exemplar_name << ": no response";
        return "";
    }
    if (status) *status = res->status;
    if (res->status != 200 && res->status != 201) {
        ADD_FAILURE() << "upload of " << exemplar_name << ": " << res->status << " " << res->body;
        return "";
    }
    return nlohmann::json::parse(res->body).at("id").get<std::string>();
}

http::ServeConfig TestServer::default_config() {
    static int counter = 0;
    http::ServeConfig c;
    c.port = 0;
    c.backend = render::BackendKind::cpu;
    c.data_dir = fresh_dir("server-" + std::to_string(counter++));
    c.access_log = false;
    c.http_threads = 96;
    return c;
}

TestServer::TestServer(http::ServeConfig config) : m_config(std::move(config)) {
    auto s = http::TextondServer::create(m_config);
    if (!s) throw std::runtime_error("cannot create the service: " + s.error().message);
    m_service = std::move(s.value());
    auto port = m_service->bind();
    if (!port) throw std::runtime_error("cannot bind: " + port.error().message);
    m_port = port.value();
    m_thread = std::thread([this] { m_service->run(); });
}

TestServer::~TestServer() {
    m_service->stop();
    if (m_thread.joinable()) m_thread.join();
}

httplib::Client TestServer::client() const {
    httplib::Client c("127.0.0.1", m_port);
    c.set_read_timeout(120, 0);
    return c;
}

ServerProcess::ServerProcess(const std::string& data_dir, const std::vector<std::string>& extra,
                             unsigned long file_size_limit) {
    int out[2];
    if (::pipe(out) != 0) throw std::runtime_error("pipe");
    m_pid = ::fork();
    if (m_pid == 0) {
        ::dup2(out[1], 1);
        ::close(out[0]);
        ::close(out[1]);
        if (file_size_limit > 0) {
            ::signal(SIGXFSZ, SIG_IGN); // kept across exec
            const rlimit lim{file_size_limit, file_size_limit};
            ::setrlimit(RLIMIT_FSIZE, &lim);
        }
        std::vector<std::string> args = {TEXTOND_BINARY, "serve",  "--port",    "0",
                                         "--data",       data_dir, "--backend", "cpu",
                                         "--log-level",  "warn"};
        args.insert(args.end(), extra.begin(), extra.end());
        std::vector<char*> argv;
        for (auto& a : args) argv.push_back(a.data());
        argv.push_back(nullptr);
        ::execv(argv[0], argv.data());
        std::_Exit(127);
    }
    ::close(out[1]);
    // The first line on stdout names the URL: "textond listening on http://127.0.0.1:PORT/".
    std::string line;
    char ch;
    while (::read(out[0], &ch, 1) == 1 && ch != '\n') line += ch;
    ::close(out[0]);
    const auto colon = line.rfind(':');
    if (colon == std::string::npos) throw std::runtime_error("server did not start: " + line);
    m_port = std::stoi(line.substr(colon + 1));
}

ServerProcess::~ServerProcess() {
    if (m_pid > 0) kill_hard();
}

httplib::Client ServerProcess::client() const {
    httplib::Client c("127.0.0.1", m_port);
    c.set_read_timeout(120, 0);
    return c;
}

void ServerProcess::kill_hard() {
    if (m_pid <= 0) return;
    ::kill(m_pid, SIGKILL);
    ::waitpid(m_pid, nullptr, 0);
    m_pid = -1;
}

int ServerProcess::terminate(int timeout_ms) {
    if (m_pid <= 0) return -1;
    ::kill(m_pid, SIGTERM);
    for (int waited = 0; waited < timeout_ms; waited += 10) {
        int status = 0;
        if (::waitpid(m_pid, &status, WNOHANG) == m_pid) {
            m_pid = -1;
            return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return -1;
}

namespace {
int free_port() {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0)
        throw std::runtime_error("no free port");
    ::close(fd);
    return ntohs(a.sin_port);
}
} // namespace

RedisProcess::RedisProcess(const std::string& dir) : m_dir(dir), m_port(free_port()) {
    start();
}

RedisProcess::~RedisProcess() {
    stop();
}

void RedisProcess::start() {
    if (m_pid > 0) return;
    m_pid = ::fork();
    if (m_pid == 0) {
        const int null = ::open("/dev/null", O_WRONLY);
        ::dup2(null, 1);
        const std::string port = std::to_string(m_port);
        ::execlp("redis-server", "redis-server", "--port", port.c_str(), "--bind", "127.0.0.1",
                 "--dir", m_dir.c_str(), "--save", "", "--appendonly", "yes", "--appendfsync",
                 "always", static_cast<char*>(nullptr));
        std::fprintf(stderr, "cannot run redis-server (docker/install-deps.sh installs it)\n");
        std::_Exit(127);
    }
    for (int waited = 0; waited < 10000; waited += 20) {
        if (cli({"PING"}).find("PONG") != std::string::npos) return;
        int status = 0;
        if (::waitpid(m_pid, &status, WNOHANG) == m_pid) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    throw std::runtime_error("redis-server did not start on port " + std::to_string(m_port));
}

void RedisProcess::stop() {
    if (m_pid <= 0) return;
    ::kill(m_pid, SIGTERM);
    ::waitpid(m_pid, nullptr, 0);
    m_pid = -1;
}

std::string RedisProcess::cli(const std::vector<std::string>& args,
                              const std::string& input) const {
    const std::string in_file = m_dir + "/cli-input";
    {
        std::ofstream f(in_file, std::ios::binary);
        f << input;
    }
    std::string cmd = "redis-cli -p " + std::to_string(m_port);
    for (const auto& a : args) cmd += " '" + a + "'";
    cmd += " < " + in_file + " 2>&1";
    std::string out;
    if (FILE* p = ::popen(cmd.c_str(), "r")) {
        char buf[4096];
        std::size_t n;
        while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
        ::pclose(p);
    }
    return out;
}

} // namespace textond::test
