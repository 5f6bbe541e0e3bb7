#pragma once
// Prometheus counters and histograms for /metrics, in the text exposition format 0.0.4. Label
// sets are small and fixed (route templates, not URLs), so a map under one mutex is enough.
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <ostream>
#include <string>
#include <vector>

namespace textond::app {

class Metrics {
public:
    // Request latency buckets (seconds): a warm tile is ~0.1 ms, an analysis seconds.
    static constexpr std::array<double, 12> kLatencyBuckets = {
        0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 5};

    void request(const std::string& route, const std::string& method, int status, double seconds);
    // A request's method as its label: one of HTTP's methods, else "other". A method the client
    // made up would add a series a request (2,000 of 8 kB took /metrics from 0.8 MB to 17 MB).
    static std::string method_label(const std::string& method);
    void render(const std::string& backend, const std::string& kind, double ms);
    void tile_cache(bool hit);
    // Where an image request's time goes: "queue" (waiting for a render slot), "render",
    // "encode", "send" (from the response being ready to its last byte handed to the socket).
    void stage(const char* stage, double seconds);
    // Work not admitted: "too_large" (413), "busy" (429), "gone" (client left while waiting).
    void not_admitted(const std::string& why);
    // Admitted work stopped before its end: its deadline passed, or its client left.
    void abandoned(bool deadline);
    void analysis(bool ok, double ms);
    // The backends serving tiles and frames, and what `auto` measured to pick them (backend,
    // 16 tiles ms, HD frame ms).
    struct CalibrationFigure {
        std::string backend;
        double tiles16_ms, hd_frame_ms;
    };
    void backends(const std::string& tiles, const std::string& frames,
                  std::vector<CalibrationFigure> figures);
    // Values read when /metrics is scraped (queue depth, store size, cache bytes).
    void gauge(const std::string& name, const std::string& help, std::function<double()> read);

    std::uint64_t analyses() const;
    std::string prometheus_text() const;

private:
    // The two halves of prometheus_text, under m_mutex: the requests' time, then the work's.
    void write_requests_locked(std::ostream& o) const;
    void write_work_locked(std::ostream& o) const;
    struct Histogram {
        std::array<std::uint64_t, kLatencyBuckets.size()> buckets{};
        std::uint64_t count = 0;
        double sum = 0;
        void observe(double v);
    };
    struct Gauge {
        std::string help;
        std::function<double()> read;
    };
    mutable std::mutex m_mutex;
    std::map<std::array<std::string, 3>, std::uint64_t> m_requests; // route, method, status
    std::map<std::array<std::string, 2>, Histogram> m_latency;      // route, status
    std::map<std::array<std::string, 2>, Histogram> m_render_ms;    // backend, kind (seconds)
    std::map<std::string, Histogram> m_stages;                      // queue, render, encode, send
    std::uint64_t m_cache_hits = 0, m_cache_misses = 0;
    std::map<std::string, std::uint64_t> m_not_admitted;
    std::uint64_t m_abandoned_deadline = 0, m_abandoned_gone = 0;
    std::uint64_t m_analyses_ok = 0, m_analyses_failed = 0;
    Histogram m_analysis_seconds;
    std::map<std::string, Gauge> m_gauges;
    std::string m_tiles_backend, m_frames_backend;
    std::vector<CalibrationFigure> m_calibration;
};

} // namespace textond::app
