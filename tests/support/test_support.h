#pragma once
#include "core/image.h"
#include "core/random.h"

#include <string>
#include <vector>

namespace textond::test {

std::string exemplar_path(const std::string& name);
core::Image load_exemplar(const std::string& name); // fails the test if missing
core::Image crop(const core::Image& u, int w, int h);
// The w x h window of `src` at (x0, y0).
core::Image window(const core::Image& src, int x0, int y0, int w, int h);
core::Image white_noise(int w, int h, int c, std::uint64_t seed);
double max_abs_diff(const core::Image& a, const core::Image& b);

// A path in the system temp directory, unique to this test process, removed (file or folder)
// when the process exits unless TEXTOND_KEEP_TEST_FILES=1.
std::string temp_path(const std::string& name);

// Runs the textond binary with `args` (a shell command line after the program's name).
struct RunResult {
    int code = -1;
    std::string out, err;
};
RunResult run(const std::string& args);

// Sample moments of one plane (double accumulation).
struct Moments {
    double mean = 0, variance = 0, excess_kurtosis = 0;
};
Moments moments(const float* p, std::size_t n);

// The mean of independent estimates and its standard error (their spread / sqrt(n)).
struct Estimate {
    double mean = 0, se = 0;
};
Estimate estimate_of(const std::vector<double>& v);

} // namespace textond::test
