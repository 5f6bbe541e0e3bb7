#include "tests/support/test_support.h"

#include "server/io/image_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <set>
#include <stdexcept>
#include <sys/wait.h>
#include <unistd.h>

namespace textond::test {

std::string exemplar_path(const std::string& name) {
    return std::string(TEXTOND_EXEMPLARS) + "/" + name;
}

core::Image load_exemplar(const std::string& name) {
    auto r = io::decode_image_file(exemplar_path(name));
    if (!r) throw std::runtime_error("cannot load exemplar " + name + ": " + r.error().message);
    return std::move(r.value());
}

core::Image crop(const core::Image& u, int w, int h) {
    core::Image out(w, h, u.channels);
    for (int c = 0; c < u.channels; ++c)
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) out.at(c, x, y) = u.at(c, x, y);
    return out;
}

core::Image white_noise(int w, int h, int c, std::uint64_t seed) {
    core::Image out(w, h, c);
    core::Rng rng(seed);
    for (auto& v : out.data) v = static_cast<float>(rng.normal());
    return out;
}

double max_abs_diff(const core::Image& a, const core::Image& b) {
    if (a.data.size() != b.data.size()) return INFINITY;
    double d = 0;
    for (std::size_t k = 0; k < a.data.size(); ++k)
        d = std::max(d, std::abs(static_cast<double>(a.data[k]) - b.data[k]));
    return d;
}

namespace {

// Every temp path a test process named is removed when it exits (a shared-store test alone left
// a 100 MB Redis log a run, and thousands of runs filled the disk). A forked child that exits
// without exec must not remove its parent's files, so the owner's pid is kept.
// TEXTOND_KEEP_TEST_FILES=1 keeps them for a post-mortem.
class TempPaths {
public:
    void add(const std::string& path) {
        const std::lock_guard<std::mutex> lock(m_mutex);
        m_paths.insert(path);
    }
    TempPaths(const TempPaths&) = delete;
    TempPaths& operator=(const TempPaths&) = delete;
    TempPaths() = default;
    ~TempPaths() {
        const char* keep = std::getenv("TEXTOND_KEEP_TEST_FILES");
        if (::getpid() != m_owner || (keep && std::string(keep) == "1")) return;
        std::error_code ignored;
        for (const auto& p : m_paths) std::filesystem::remove_all(p, ignored);
    }

private:
    std::mutex m_mutex;
    std::set<std::string> m_paths;
    pid_t m_owner = ::getpid();
};

TempPaths& temp_paths() {
    static TempPaths paths;
    return paths;
}

} // namespace

std::string temp_path(const std::string& name) {
    const std::string path = (std::filesystem::temp_directory_path() /
                              ("textond-test-" + std::to_string(::getpid()) + "-" + name))
                                 .string();
    temp_paths().add(path);
    return path;
}

Moments moments(const float* p, std::size_t n) {
    Moments m;
    double s = 0;
    for (std::size_t k = 0; k < n; ++k) s += p[k];
    m.mean = s / static_cast<double>(n);
    double m2 = 0, m4 = 0;
    for (std::size_t k = 0; k < n; ++k) {
        const double d = p[k] - m.mean;
        m2 += d * d;
        m4 += d * d * d * d;
    }
    m2 /= static_cast<double>(n);
    m4 /= static_cast<double>(n);
    m.variance = m2;
    m.excess_kurtosis = m2 > 0 ? m4 / (m2 * m2) - 3.0 : 0.0;
    return m;
}

core::Image window(const core::Image& src, int x0, int y0, int w, int h) {
    core::Image out(w, h, src.channels);
    for (int c = 0; c < src.channels; ++c)
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) out.at(c, x, y) = src.at(c, x0 + x, y0 + y);
    return out;
}

Estimate estimate_of(const std::vector<double>& v) {
    Estimate e;
    for (double x : v) e.mean += x;
    e.mean /= static_cast<double>(v.size());
    double s = 0;
    for (double x : v) s += (x - e.mean) * (x - e.mean);
    e.se = std::sqrt(s / static_cast<double>(v.size() - 1) / static_cast<double>(v.size()));
    return e;
}

RunResult run(const std::string& args) {
    static std::atomic<int> calls{0}; // runs may overlap (threads): a file each
    const std::string errfile = temp_path("run-stderr-" + std::to_string(calls++));
    const std::string cmd = std::string(TEXTOND_BINARY) + " " + args + " 2>" + errfile;
    RunResult r;
    FILE* p = ::popen(cmd.c_str(), "r");
    if (!p) return r;
    std::array<char, 4096> buf{};
    while (std::size_t n = std::fread(buf.data(), 1, buf.size(), p)) r.out.append(buf.data(), n);
    const int status = ::pclose(p);
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    if (std::FILE* e = std::fopen(errfile.c_str(), "r")) {
        while (std::size_t n = std::fread(buf.data(), 1, buf.size(), e))
            r.err.append(buf.data(), n);
        std::fclose(e);
    }
    std::remove(errfile.c_str());
    return r;
}

} // namespace textond::test
