#include "server/app/build_id.h"
#include "server/cli/commands.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fcntl.h>
#include <iostream>
#include <string>
#include <unistd.h>

namespace {
const char* kUsage = R"(textond: exemplar photo -> texton -> infinite seamless texture

usage: textond <command> [options]

commands:
  analyze   estimate the Gaussian model of an exemplar and compute its texton (+ RME)
  synth     reference synthesis (ADSN, RPN, discrete spot noise) from an exemplar or texton
  render    evaluate a window of texton noise (any position, level, seed) on a backend
  mix       mix two exemplars across space (optimal-transport barycentres, a ramp or a mask)
  serve     run the HTTP service (textond serve --help; api/README.md "HTTP API")
  bench     benchmarks (textond bench analyze | render)
  probe     GET a URL, exit 0 on 2xx (the container HEALTHCHECK)
  sign      sign an image URL for a server run with --url-signing-key
  export    write a texton's tiles over a box and zooms into an MBTiles or PMTiles archive

  textond <command> --help   options of one command
  textond --version
)";
} // namespace

namespace textond::cli {
int fail(int code, const std::string& message) {
    std::fprintf(stderr, "textond: %s\n", message.c_str());
    return code;
}
} // namespace textond::cli

namespace {
// The service runs OpenMP analyses next to many render and HTTP threads. libgomp's default
// policy spins at every barrier, and a spinning team whose other member was preempted stalls
// for whole time slices: under load an analysis took 56x longer (39 s instead of 0.7 s).
// libgomp reads OMP_WAIT_POLICY once, when it is loaded, so `serve` re-executes itself with the
// passive policy unless the caller chose one.
// NVIDIA's OpenGL driver spins with sched_yield wherever it waits for the GPU (a buffer still in
// use, a sync object): __GL_YIELD=USLEEP makes it sleep instead, unless the caller chose. The
// backends poll their own fences (render/gl/fence_wait.h); this covers the driver's other waits.
void passive_waits_for_serve(int argc, char** argv) {
    if (argc < 2 || std::string(argv[1]) != "serve") return;
    const char* gl_wait = std::getenv("TEXTOND_GL_WAIT"); // "driver": as before, to compare
    if (!gl_wait || std::string(gl_wait) != "driver") ::setenv("__GL_YIELD", "USLEEP", 0);
    if (std::getenv("OMP_WAIT_POLICY")) return;
    ::setenv("OMP_WAIT_POLICY", "PASSIVE", 1);
    ::execv("/proc/self/exe", argv);
    // exec failed: carry on with the active policy (slower under load, still correct)
}

// Started with a standard descriptor closed (`2>&-`), the process would hand that number to the
// next file it opens: the listening socket or a client's connection would become stderr, and a
// library's error line would be written to a client. /dev/null takes each closed one first.
void open_closed_standard_descriptors() {
    for (int fd = 0; fd <= 2; ++fd) {
        if (::fcntl(fd, F_GETFD) != -1 || errno != EBADF) continue;
        const int null = ::open("/dev/null", O_RDWR); // the lowest free number: fd itself
        if (null >= 0 && null != fd) {
            ::dup2(null, fd);
            ::close(null);
        }
    }
}
} // namespace

int main(int argc, char** argv) {
    open_closed_standard_descriptors();
    passive_waits_for_serve(argc, argv);
    // Logs and progress go to stderr; stdout carries only the command's result (JSON, tables).
    spdlog::set_default_logger(spdlog::stderr_color_mt("textond"));
    spdlog::set_pattern(textond::cli::kLogPattern);
    if (argc < 2) {
        std::fputs(kUsage, stderr);
        return 2;
    }
    const std::string cmd = argv[1];
    const textond::cli::Argv rest(argv + 2, argv + argc);
    try {
        if (cmd == "--help" || cmd == "-h" || cmd == "help") {
            std::fputs(kUsage, stdout);
            return 0;
        }
        if (cmd == "--version") {
            // The build id (as /healthz's "build") names what made a tile's bytes: an image
            // built for the same bytes as a host build takes its commit from here.
            std::printf("textond 0.1.0\nbuild: %s\n", textond::app::build_id().c_str());
            return 0;
        }
        if (cmd == "analyze") return textond::cli::analyze_command(rest);
        if (cmd == "synth") return textond::cli::synth_command(rest);
        if (cmd == "render") return textond::cli::render_command(rest);
        if (cmd == "mix") return textond::cli::mix_command(rest);
        if (cmd == "bench") return textond::cli::bench_command(rest);
        if (cmd == "serve") return textond::cli::serve_command(rest);
        if (cmd == "probe") return textond::cli::probe_command(rest);
        if (cmd == "sign") return textond::cli::sign_command(rest);
        if (cmd == "export") return textond::cli::export_command(rest);
        std::fputs(kUsage, stderr);
        return textond::cli::fail(2, "unknown command '" + cmd + "'");
    } catch (const std::exception& e) {
        return textond::cli::fail(1, std::string("internal error: ") + e.what());
    }
}
