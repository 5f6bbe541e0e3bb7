#include "render/window_batcher.h"

#include "render/gl/noise_window.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <vector>

namespace textond::render {

WindowBatcher::WindowBatcher(std::vector<std::shared_ptr<GlBackend>> lanes, int max_tiles,
                             std::chrono::microseconds max_wait, double max_ms)
    : m_lanes(std::move(lanes)), m_max_tiles(std::max(1, max_tiles)),
      m_max_wait(std::max(std::chrono::microseconds(0), max_wait)), m_max_ms(max_ms) {
    for (const auto& lane : m_lanes) m_workers.emplace_back([this, &lane] { run(*lane); });
}

WindowBatcher::~WindowBatcher() {
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        m_stop = true;
    }
    m_queued.notify_all();
    for (std::thread& w : m_workers) w.join();
}

Result<core::Image> WindowBatcher::render(const PreparedTexton& texton, const PreparedMix* mix,
                                          const NoiseRequest& request) {
    auto work = m_lanes.front()->prepare(texton, mix, request); // on the caller's thread
    if (!work) return work.error();
    Job job{std::move(work.value())};
    {
        std::unique_lock<std::mutex> lock(m_mutex);
        if (m_stop) return make_error(ErrorCode::unavailable, "the renderer is stopping");
        m_queue.push_back(&job);
        m_queued.notify_one();
        m_done.wait(lock, [&] { return job.done; });
    }
    return std::move(job.work.image);
}

void WindowBatcher::run(GlBackend& gl) {
    auto pixels_of = [](const Job& job) {
        return static_cast<double>(job.work.window->width) * job.work.window->height;
    };
    std::unique_lock<std::mutex> lock(m_mutex);
    for (;;) {
        m_queued.wait(lock, [&] { return m_stop || !m_queue.empty(); });
        if (m_queue.empty()) return; // stopping, nothing left
        // The first window is here: wait a little for more, unless the batch is full already.
        if (static_cast<int>(m_queue.size()) < m_max_tiles && m_max_wait.count() > 0)
            m_queued.wait_for(lock, m_max_wait, [&] {
                return m_stop || static_cast<int>(m_queue.size()) >= m_max_tiles;
            });
        // Every window of a batch is answered when the batch ends, so a batch holds at most
        // m_max_ms of measured work (always one window): a GPU takes all 64 tiles at once,
        // llvmpipe (60 ms a tile) one at a time. Until a batch has been measured, one window: a
        // first batch of 64 on llvmpipe would answer nothing for 30 s.
        const double budget_px = m_ms_per_pixel > 0 ? m_max_ms / m_ms_per_pixel : 0;
        std::vector<Job*> jobs;
        double pixels = 0;
        while (!m_queue.empty() && static_cast<int>(jobs.size()) < m_max_tiles) {
            const double px = pixels_of(*m_queue.front());
            if (!jobs.empty() && pixels + px > budget_px) break;
            pixels += px;
            jobs.push_back(m_queue.front());
            m_queue.pop_front();
        }
        lock.unlock();
        std::vector<GlBackend::Work*> batch;
        batch.reserve(jobs.size());
        for (Job* j : jobs) batch.push_back(&j->work);
        const auto t0 = std::chrono::steady_clock::now();
        try {
            gl.render_batch(batch);
        } catch (const std::exception& e) { // bad_alloc: fail the batch, not the process
            for (Job* j : jobs) j->work.image = Error{ErrorCode::internal, e.what()};
        }
        const double ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count();
        lock.lock();
        const double rate = ms / std::max(1.0, pixels);
        m_ms_per_pixel = m_ms_per_pixel > 0 ? 0.7 * m_ms_per_pixel + 0.3 * rate : rate;
        ++m_batches;
        m_windows += jobs.size();
        for (Job* j : jobs) j->done = true;
        m_done.notify_all();
    }
}

std::uint64_t WindowBatcher::batches() const {
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_batches;
}

std::uint64_t WindowBatcher::windows() const {
    std::lock_guard<std::mutex> lock(m_mutex);
    return m_windows;
}

} // namespace textond::render
