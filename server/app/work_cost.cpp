#include "server/app/work_cost.h"

#include "core/noise_levels.h"
#include "core/working_window.h"

#include <algorithm>
#include <cmath>

namespace textond::app {

int taps_of_order(int order) {
    return order == 3 ? 16 : order == 1 ? 4 : 1;
}

double noise_work_s(std::int64_t pixels, double mni, int order) {
    return static_cast<double>(pixels) * mni * taps_of_order(order) * 1.5e-9;
}

double zoomed_points_work_s(std::int64_t w, std::int64_t h, int level, double mni, int size) {
    constexpr double kPointNs = 240;
    if (level <= 0 || size <= 0 || level >= core::noise::limit_level(size)) return 0;
    const double span = std::ldexp(1.0, level);
    const double points = (static_cast<double>(w) * span + size) *
                          (static_cast<double>(h) * span + size) * mni /
                          (static_cast<double>(size) * size);
    return points * kPointNs * 1e-9;
}

double surface_work_s(std::size_t points, double mni, int order) {
    return static_cast<double>(points) * mni * taps_of_order(order) * 55e-9;
}

double mesh_work_s(std::uint64_t raster_tests, std::int64_t pixels, double mni, int order) {
    return static_cast<double>(raster_tests) * 10e-9 +
           surface_work_s(static_cast<std::size_t>(pixels), mni, order);
}

double fft_sides_factor(int width, int height) {
    // tests/bench/analysis_cost.py, its "sides" form
    constexpr double kFactor5 = 0.45, kFactor7 = 1.00;
    auto side = [](int n) { return (n % 5 == 0 ? kFactor5 : 0.0) + (n % 7 == 0 ? kFactor7 : 0.0); };
    return 1 + (side(width) + side(height)) / 2;
}

double analysis_work_s(int width, int height, int channels, int iterations, int size) {
    // tests/bench/analysis_cost.py, its "sides" form
    constexpr double kIterationNs = 4.37, kChannelPixelNs = 54.03, kPixelNs = 180.31;
    constexpr double kFixedS = 0.04517;
    const auto [w, h] = core::window_size(width, height, core::kWorkingSide, 2 * size);
    const double fft = fft_sides_factor(w, h);
    const double pixels = static_cast<double>(w) * h, channel_pixels = pixels * channels;
    const double whole = static_cast<double>(width) * height * channels;
    return fft *
               (channel_pixels * (iterations * kIterationNs + kChannelPixelNs) +
                pixels * kPixelNs) *
               1e-9 +
           kFixedS + whole * 10e-9;
}

double mix_work_s(int width, int height, int channels, int iterations, int levels) {
    constexpr double kMixNs = 3.32, kMixFixedIterations = 13.1; // tests/bench/mix_cost.py
    const double pixels = static_cast<double>(width) * height;
    return levels * pixels * channels * (iterations + kMixFixedIterations) * kMixNs * 1e-9 *
           std::log2(std::max(pixels, 2.0)) / 16 * fft_sides_factor(width, height);
}

} // namespace textond::app
