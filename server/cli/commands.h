#pragma once
// Subcommands of the `textond` executable. Each returns the process exit code:
// 0 success, 1 the work failed (bad input file, I/O), 2 the command line is wrong.
#include <string>
#include <vector>

namespace textond::cli {

using Argv = std::vector<std::string>;

int analyze_command(const Argv& args);
int synth_command(const Argv& args);
int bench_command(const Argv& args);
int bench_render_command(const Argv& args);
int bench_tile_command(const Argv& args);
int render_command(const Argv& args);
int mix_command(const Argv& args);
int serve_command(const Argv& args);
int probe_command(const Argv& args);
int sign_command(const Argv& args);
int export_command(const Argv& args);

// Every log line's form: time, level, message (main sets it; StderrCapture keeps it).
inline constexpr const char* kLogPattern = "[%H:%M:%S.%e] %^%l%$ %v";

// Prints "textond: <message>" to stderr and returns `code`.
int fail(int code, const std::string& message);

} // namespace textond::cli
