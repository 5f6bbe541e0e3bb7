#include "core/fft2d.h"

#include <fftw3.h>

#include <algorithm>
#include <cstring>
#include <list>
#include <mutex>
#include <new>
#include <stdexcept>
#include <thread>
#include <utility>

#include <omp.h>

namespace textond::core {

namespace {
constexpr int kColumnBatch = 8; // columns per strided 1-D plan call; keeps 64-byte alignment
std::mutex g_planner_mutex;     // only fftwf_execute* is thread-safe in FFTW

std::size_t padded_stride(int cwidth) {
    return (static_cast<std::size_t>(cwidth) + 7) / 8 * 8;
}

struct FloatBuffer {
    explicit FloatBuffer(std::size_t n) : p(static_cast<float*>(fftwf_malloc(sizeof(float) * n))) {
        if (!p) throw std::bad_alloc();
    }
    ~FloatBuffer() { fftwf_free(p); }
    FloatBuffer(const FloatBuffer&) = delete;
    FloatBuffer& operator=(const FloatBuffer&) = delete;
    float* p;
};
} // namespace

void Spectrum::Free::operator()(cfloat* p) const {
    fftwf_free(p);
}

Spectrum::Spectrum(int width, int height)
    : m_width(width), m_height(height), m_stride(padded_stride(width / 2 + 1)) {
    if (width <= 0 || height <= 0) throw std::invalid_argument("Spectrum: empty size");
    const std::size_t n = m_stride * static_cast<std::size_t>(height);
    auto* p = static_cast<cfloat*>(fftwf_malloc(sizeof(cfloat) * n));
    if (!p) throw std::bad_alloc();
    std::fill(p, p + n, cfloat(0.0f, 0.0f));
    m_data.reset(p);
}

Spectrum::Spectrum(const Spectrum& other) : Spectrum() {
    *this = other;
}

Spectrum& Spectrum::operator=(const Spectrum& other) {
    if (this == &other) return *this;
    if (!other.m_data) {
        m_data.reset();
        m_width = m_height = 0;
        m_stride = 0;
        return *this;
    }
    Spectrum copy(other.m_width, other.m_height);
    std::memcpy(copy.m_data.get(), other.m_data.get(),
                sizeof(cfloat) * other.m_stride * static_cast<std::size_t>(other.m_height));
    *this = std::move(copy);
    return *this;
}

struct RealFft2d::Plans {
    fftwf_plan row_r2c = nullptr;
    fftwf_plan row_c2r = nullptr;
    fftwf_plan col_fwd = nullptr; // kColumnBatch columns
    fftwf_plan col_bwd = nullptr;
    fftwf_plan col_fwd_tail = nullptr; // the cwidth % kColumnBatch last columns
    fftwf_plan col_bwd_tail = nullptr;
    ~Plans() {
        std::lock_guard<std::mutex> lock(g_planner_mutex);
        for (fftwf_plan p : {row_r2c, row_c2r, col_fwd, col_bwd, col_fwd_tail, col_bwd_tail})
            if (p) fftwf_destroy_plan(p);
    }
};

int resolve_threads(int requested) {
    if (requested > 0) return requested;
    const unsigned hw = std::thread::hardware_concurrency();
    return hw == 0 ? 1 : static_cast<int>(hw);
}

namespace {
// Most recently used first; a size in use elsewhere outlives its eviction (shared_ptr).
struct PlanCache {
    std::mutex mutex;
    std::list<std::pair<std::pair<int, int>, std::shared_ptr<const RealFft2d>>> sizes;
};
PlanCache& plan_cache() {
    static PlanCache cache;
    return cache;
}
} // namespace

std::shared_ptr<const RealFft2d> RealFft2d::get(int width, int height) {
    PlanCache& cache = plan_cache();
    std::unique_lock<std::mutex> lock(cache.mutex);
    const std::pair<int, int> key{width, height};
    for (auto it = cache.sizes.begin(); it != cache.sizes.end(); ++it)
        if (it->first == key) {
            cache.sizes.splice(cache.sizes.begin(), cache.sizes, it);
            return it->second;
        }
    std::shared_ptr<const RealFft2d> made(new RealFft2d(width, height));
    cache.sizes.emplace_front(key, made);
    std::shared_ptr<const RealFft2d> evicted;
    if (cache.sizes.size() > kCachedSizes) {
        evicted = std::move(cache.sizes.back().second);
        cache.sizes.pop_back();
    }
    lock.unlock(); // its plans are destroyed under the planner's lock, not the cache's
    if (evicted) {
        evicted.reset();
        // FFTW remembers every problem it planned (its wisdom), about 70 bytes each: forgotten
        // with the sizes it planned, so the memory stays bounded too (plans in use keep theirs).
        std::lock_guard<std::mutex> planner(g_planner_mutex);
        fftwf_forget_wisdom();
    }
    return made;
}

std::size_t RealFft2d::cached_sizes() {
    PlanCache& cache = plan_cache();
    std::lock_guard<std::mutex> lock(cache.mutex);
    return cache.sizes.size();
}

RealFft2d::RealFft2d(int width, int height)
    : m_width(width), m_height(height), m_plans(std::make_unique<Plans>()) {
    if (width <= 0 || height <= 0) throw std::invalid_argument("RealFft2d: empty size");
    // Plan on scratch arrays laid out exactly like the ones we execute on (FFTW_ESTIMATE never
    // reads or writes them).
    Spectrum spec(width, height);
    FloatBuffer row(static_cast<std::size_t>(width) + 16);
    const int cw = width / 2 + 1;
    const int stride = static_cast<int>(spec.stride());
    auto* c = reinterpret_cast<fftwf_complex*>(spec.data());
    const unsigned flags = FFTW_ESTIMATE;

    std::lock_guard<std::mutex> lock(g_planner_mutex);
    Plans& p = *m_plans;
    p.row_r2c = fftwf_plan_dft_r2c_1d(width, row.p, c, flags);
    p.row_c2r = fftwf_plan_dft_c2r_1d(width, c, row.p, flags | FFTW_DESTROY_INPUT);
    auto column_plan = [&](int howmany, int sign) {
        int n = height;
        return fftwf_plan_many_dft(1, &n, howmany, c, nullptr, stride, 1, c, nullptr, stride, 1,
                                   sign, flags);
    };
    p.col_fwd = column_plan(kColumnBatch, FFTW_FORWARD);
    p.col_bwd = column_plan(kColumnBatch, FFTW_BACKWARD);
    if (cw % kColumnBatch != 0) {
        p.col_fwd_tail = column_plan(cw % kColumnBatch, FFTW_FORWARD);
        p.col_bwd_tail = column_plan(cw % kColumnBatch, FFTW_BACKWARD);
    }
    if (!p.row_r2c || !p.row_c2r || !p.col_fwd || !p.col_bwd)
        throw std::runtime_error("FFTW could not make a plan");
}

RealFft2d::~RealFft2d() = default;

namespace {
void run_columns(const RealFft2d::Plans& p, bool forward, Spectrum& s, int threads) {
    const int cw = s.cwidth();
    const int batches = (cw + kColumnBatch - 1) / kColumnBatch;
    const int full = cw / kColumnBatch;
    fftwf_plan batch = forward ? p.col_fwd : p.col_bwd;
    fftwf_plan tail = forward ? p.col_fwd_tail : p.col_bwd_tail;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int b = 0; b < batches; ++b) {
        auto* ptr =
            reinterpret_cast<fftwf_complex*>(s.data() + static_cast<std::size_t>(b) * kColumnBatch);
        fftwf_execute_dft(b < full ? batch : tail, ptr, ptr);
    }
}
} // namespace

void RealFft2d::forward(const float* in, std::size_t in_stride, int rows, int cols, Spectrum& out,
                        int threads) const {
    if (out.width() != m_width || out.height() != m_height) out = Spectrum(m_width, m_height);
    rows = std::clamp(rows, 0, m_height);
    cols = std::clamp(cols, 0, m_width);
    threads = std::max(1, std::min(resolve_threads(threads), m_height));
    const int cw = out.cwidth();
#pragma omp parallel num_threads(threads)
    {
        FloatBuffer row(static_cast<std::size_t>(m_width) + 16);
        std::fill(row.p + cols, row.p + m_width, 0.0f);
#pragma omp for schedule(static)
        for (int y = 0; y < rows; ++y) {
            std::memcpy(row.p, in + in_stride * static_cast<std::size_t>(y), sizeof(float) * cols);
            fftwf_execute_dft_r2c(m_plans->row_r2c, row.p,
                                  reinterpret_cast<fftwf_complex*>(out.row(y)));
        }
#pragma omp for schedule(static)
        for (int y = rows; y < m_height; ++y) std::fill(out.row(y), out.row(y) + cw, cfloat());
    }
    run_columns(*m_plans, true, out, threads);
}

void RealFft2d::inverse(Spectrum& spec, float* out, std::size_t out_stride, int rows, int cols,
                        int threads) const {
    if (spec.width() != m_width || spec.height() != m_height)
        throw std::invalid_argument("RealFft2d::inverse: spectrum of another size");
    rows = std::clamp(rows, 0, m_height);
    cols = std::clamp(cols, 0, m_width);
    threads = std::max(1, std::min(resolve_threads(threads), m_height));
    run_columns(*m_plans, false, spec, threads);
#pragma omp parallel num_threads(threads)
    {
        FloatBuffer row(static_cast<std::size_t>(m_width) + 16);
#pragma omp for schedule(static)
        for (int y = 0; y < rows; ++y) {
            fftwf_execute_dft_c2r(m_plans->row_c2r, reinterpret_cast<fftwf_complex*>(spec.row(y)),
                                  row.p);
            std::memcpy(out + out_stride * static_cast<std::size_t>(y), row.p,
                        sizeof(float) * cols);
        }
    }
}

bool is_fft_friendly(int n) {
    if (n < 1) return false;
    for (int p : {2, 3, 5, 7})
        while (n % p == 0) n /= p;
    return n == 1;
}

int fft_friendly_size(int n) {
    for (int m = std::max(1, n);; ++m)
        if (is_fft_friendly(m)) return m;
}

} // namespace textond::core
