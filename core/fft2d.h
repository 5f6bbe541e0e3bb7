#pragma once
// 2-D real FFTs on FFTW's float interface, as row and column passes of 1-D plans.
//
// Why not one fftwf_plan_dft_r2c_2d: (1) the alternating projections only need the r x r corner
// of the inverse and feed back an image that is zero outside it, so the row passes can be pruned
// to r rows; (2) we split independent 1-D transforms across threads ourselves, so every value is
// computed by the same plan in the same order whatever the thread count (bit-identical output).
// Plans are made once per size (FFTW_ESTIMATE: no timing, same plan on every run) and shared.
#include <complex>
#include <cstddef>
#include <memory>

namespace textond::core {

using cfloat = std::complex<float>;

// Half spectrum of a width x height real image: `height` rows of width/2+1 values. Rows are padded
// to a multiple of 8 values so every row and column batch has the alignment the plans were made
// with.
class Spectrum {
public:
    Spectrum() = default;
    Spectrum(int width, int height);
    Spectrum(const Spectrum& other);
    Spectrum& operator=(const Spectrum& other);
    Spectrum(Spectrum&&) noexcept = default;
    Spectrum& operator=(Spectrum&&) noexcept = default;

    int width() const { return m_width; }
    int height() const { return m_height; }
    int cwidth() const { return m_width / 2 + 1; }
    std::size_t stride() const { return m_stride; }
    cfloat* row(int y) { return m_data.get() + m_stride * static_cast<std::size_t>(y); }
    const cfloat* row(int y) const { return m_data.get() + m_stride * static_cast<std::size_t>(y); }
    cfloat* data() { return m_data.get(); }
    // Weight of column j when summing over the full (Hermitian) spectrum: 1 for the columns that
    // are their own mirror (0 and width/2 when width is even), 2 for the others.
    double column_weight(int j) const {
        return (j == 0 || (m_width % 2 == 0 && j == m_width / 2)) ? 1.0 : 2.0;
    }

private:
    struct Free {
        void operator()(cfloat* p) const;
    };
    int m_width = 0;
    int m_height = 0;
    std::size_t m_stride = 0;
    std::unique_ptr<cfloat[], Free> m_data;
};

class RealFft2d {
public:
    // Shared, cached per size; thread-safe (planning happens under a global lock). The cache
    // keeps the kCachedSizes sizes used last: every upload of a new size made plans that stayed
    // for the life of the process (about 46 kB a size; 1,595 sizes took +73 MB), so a client
    // sending exemplars of ever new sizes grew the server without bound.
    static constexpr std::size_t kCachedSizes = 64;
    static std::shared_ptr<const RealFft2d> get(int width, int height);
    static std::size_t cached_sizes();
    ~RealFft2d();
    RealFft2d(const RealFft2d&) = delete;
    RealFft2d& operator=(const RealFft2d&) = delete;

    int width() const { return m_width; }
    int height() const { return m_height; }

    // Forward DFT of an image that is zero outside its top-left rows x cols block; `in` holds that
    // block with row stride in_stride (floats). Unnormalised: sum_x v(x) exp(-2i pi <x, xi>).
    void forward(const float* in, std::size_t in_stride, int rows, int cols, Spectrum& out,
                 int threads) const;
    // Full-image convenience.
    void forward(const float* in, Spectrum& out, int threads) const {
        forward(in, static_cast<std::size_t>(m_width), m_height, m_width, out, threads);
    }
    // Unnormalised inverse DFT (multiply by 1/(width*height) yourself); only the top-left
    // rows x cols block is written, with row stride out_stride. `spec` is destroyed.
    void inverse(Spectrum& spec, float* out, std::size_t out_stride, int rows, int cols,
                 int threads) const;
    void inverse(Spectrum& spec, float* out, int threads) const {
        inverse(spec, out, static_cast<std::size_t>(m_width), m_height, m_width, threads);
    }

    struct Plans; // FFTW plan handles, opaque here

private:
    RealFft2d(int width, int height);
    int m_width;
    int m_height;
    std::unique_ptr<Plans> m_plans;
};

// Whether n's only prime factors are 2, 3, 5 and 7 (FFTW's fast codelets).
bool is_fft_friendly(int n);
// Smallest such size >= n (spectral synthesis pads to it).
int fft_friendly_size(int n);

// Threads to use for `requested` (0 = all hardware threads).
int resolve_threads(int requested);

} // namespace textond::core
