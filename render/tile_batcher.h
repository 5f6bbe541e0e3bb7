#pragma once
// Gathers concurrent windows for one GL backend into batches: each caller prepares
// its window on its own thread (points listed, no GL), queues it and waits; one worker takes what
// is queued (up to `max_tiles`, waiting at most `max_wait` for more once the first arrives) and
// renders it as one GlBackend::render_batch: one upload, one dispatch per level table, one
// readback per pass. A batch is also bounded by time: the worker measures the backend's speed
// and takes no more windows than it renders in about `max_ms` (at least one), so a slow renderer
// (llvmpipe) answers each window as it finishes instead of all of them at the end of a long
// batch. Tiles, regions, tileable windows and mixes share the queue.
#include "core/result.h"
#include "render/gl/gl_backend.h"

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>

namespace textond::render {

class TileBatcher {
public:
    TileBatcher(std::shared_ptr<GlBackend> gl, int max_tiles, std::chrono::microseconds max_wait,
                double max_ms = 25);
    ~TileBatcher(); // finishes what is queued, then stops the worker
    TileBatcher(const TileBatcher&) = delete;
    TileBatcher& operator=(const TileBatcher&) = delete;

    // `mix` null: texton noise of `texton`; else the mix (level 0 is `texton`).
    Result<core::Image> render(const PreparedTexton& texton, const PreparedMix* mix,
                               const NoiseRequest& request);

    // What the worker has done: batches rendered and windows in them.
    std::uint64_t batches() const;
    std::uint64_t windows() const;

private:
    struct Job {
        GlBackend::Work work;
        bool done = false;
    };
    void run();

    std::shared_ptr<GlBackend> m_gl;
    const int m_max_tiles;
    const std::chrono::microseconds m_max_wait;
    const double m_max_ms;
    mutable std::mutex m_mutex;
    std::condition_variable m_queued, m_done;
    std::deque<Job*> m_queue;
    bool m_stop = false;
    std::uint64_t m_batches = 0, m_windows = 0;
    double m_ms_per_pixel = 0; // the backend's measured speed (moving average over batches)
    std::thread m_worker;
};

} // namespace textond::render
