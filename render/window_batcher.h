#pragma once
// Gathers concurrent windows for GL backends into batches: each caller prepares its window on
// its own thread (points listed, no GL), queues it and waits; a worker takes what is queued (up to
// `max_tiles`, waiting at most `max_wait` for more once the first arrives) and renders it as one
// GlBackend::render_batch: one upload, one dispatch per level table, one readback per pass. A batch
// is also bounded by time: the worker measures the backend's speed and takes no more windows than
// it renders in about `max_ms` (at least one), so a slow renderer (llvmpipe) answers each window as
// it finishes instead of all of them at the end of a long batch. Tiles, regions, tileable windows
// and mixes share the queue.
//
// One worker a lane, each lane a GlBackend with a context of its own: a batch is upload,
// dispatch, wait, read back and convert, so with one lane the GPU idles while the host converts
// and the host idles while the GPU computes (an H100 served no more tiles than its CPUs). With
// two or more, one lane's batch computes while another's is read back and the next is gathered.
#include "core/result.h"
#include "render/gl/gl_backend.h"

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace textond::render {

class WindowBatcher {
public:
    // `lanes`: at least one; all of one kind (their windows are prepared by the first).
    WindowBatcher(std::vector<std::shared_ptr<GlBackend>> lanes, int max_tiles,
                  std::chrono::microseconds max_wait, double max_ms = 25);
    ~WindowBatcher(); // finishes what is queued, then stops the workers
    WindowBatcher(const WindowBatcher&) = delete;
    WindowBatcher& operator=(const WindowBatcher&) = delete;

    // `mix` null: texton noise of `texton`; else the mix (level 0 is `texton`).
    Result<core::Image> render(const PreparedTexton& texton, const PreparedMix* mix,
                               const NoiseRequest& request);

    // What the workers have done: batches rendered and windows in them.
    std::uint64_t batches() const;
    std::uint64_t windows() const;
    int lanes() const { return static_cast<int>(m_lanes.size()); }

private:
    struct Job {
        GlBackend::Work work;
        bool done = false;
    };
    void run(GlBackend& gl);

    std::vector<std::shared_ptr<GlBackend>> m_lanes;
    const int m_max_tiles;
    const std::chrono::microseconds m_max_wait;
    const double m_max_ms;
    mutable std::mutex m_mutex;
    std::condition_variable m_queued, m_done;
    std::deque<Job*> m_queue;
    bool m_stop = false;
    std::uint64_t m_batches = 0, m_windows = 0;
    double m_ms_per_pixel = 0; // a lane's measured speed (moving average over batches)
    std::vector<std::thread> m_workers;
};

} // namespace textond::render
