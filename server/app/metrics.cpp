#include "server/app/metrics.h"

#include "api/requests.h"

#include <cstdio>
#include <sstream>

namespace textond::app {

namespace {
using api::exact_text;
// Label values are route templates, backend names and numbers; escape anyway.
std::string esc(const std::string& s) {
    std::string out;
    for (char c : s) {
        if (c == '\\' || c == '"') out += '\\';
        if (c == '\n') {
            out += "\\n";
            continue;
        }
        out += c;
    }
    return out;
}

template <class H>
void write_histogram(std::ostream& o, const std::string& name, const std::string& labels,
                     const H& h, const std::array<double, Metrics::kLatencyBuckets.size()>& le) {
    std::uint64_t cumulative = 0;
    const std::string sep = labels.empty() ? "" : ",";
    for (std::size_t i = 0; i < le.size(); ++i) {
        cumulative += h.buckets[i];
        o << name << "_bucket{" << labels << sep << "le=\"" << exact_text(le[i]) << "\"} "
          << cumulative << "\n";
    }
    o << name << "_bucket{" << labels << sep << "le=\"+Inf\"} " << h.count << "\n";
    const std::string braced = labels.empty() ? "" : "{" + labels + "}";
    o << name << "_sum" << braced << " " << exact_text(h.sum) << "\n";
    o << name << "_count" << braced << " " << h.count << "\n";
}
} // namespace

void Metrics::Histogram::observe(double v) {
    for (std::size_t i = 0; i < kLatencyBuckets.size(); ++i)
        if (v <= kLatencyBuckets[i]) {
            ++buckets[i];
            break;
        }
    ++count;
    sum += v;
}

std::string Metrics::method_label(const std::string& method) {
    static constexpr const char* kKnown[] = {"GET",     "HEAD",  "POST",    "PUT",   "DELETE",
                                             "OPTIONS", "PATCH", "CONNECT", "TRACE", "-"};
    for (const char* m : kKnown)
        if (method == m) return method;
    return "other";
}

void Metrics::request(const std::string& route, const std::string& method, int status,
                      double seconds) {
    const std::string s = std::to_string(status);
    std::lock_guard lock(m_mutex);
    ++m_requests[{route, method_label(method), s}];
    m_latency[{route, s}].observe(seconds);
}

void Metrics::render(const std::string& backend, const std::string& kind, double ms) {
    std::lock_guard lock(m_mutex);
    m_render_ms[{backend, kind}].observe(ms / 1000.0);
}

void Metrics::not_admitted(const std::string& why) {
    std::lock_guard lock(m_mutex);
    ++m_not_admitted[why];
}

void Metrics::abandoned(bool deadline) {
    std::lock_guard lock(m_mutex);
    ++(deadline ? m_abandoned_deadline : m_abandoned_gone);
}

void Metrics::backends(const std::string& tiles, const std::string& frames,
                       std::vector<CalibrationFigure> figures) {
    std::lock_guard lock(m_mutex);
    m_tiles_backend = tiles;
    m_frames_backend = frames;
    m_calibration = std::move(figures);
}

void Metrics::stage(const char* stage, double seconds) {
    std::lock_guard lock(m_mutex);
    m_stages[stage].observe(seconds);
}

void Metrics::tile_cache(bool hit) {
    std::lock_guard lock(m_mutex);
    ++(hit ? m_cache_hits : m_cache_misses);
}

void Metrics::analysis(bool ok, double ms) {
    std::lock_guard lock(m_mutex);
    ++(ok ? m_analyses_ok : m_analyses_failed);
    m_analysis_seconds.observe(ms / 1000.0);
}

void Metrics::gauge(const std::string& name, const std::string& help,
                    std::function<double()> read) {
    std::lock_guard lock(m_mutex);
    m_gauges[name] = {help, std::move(read)};
}

std::uint64_t Metrics::analyses() const {
    std::lock_guard lock(m_mutex);
    return m_analyses_ok + m_analyses_failed;
}

void Metrics::write_requests_locked(std::ostream& o) const {
    o << "# HELP textond_http_requests_total HTTP requests by route template, method and "
         "status.\n# TYPE textond_http_requests_total counter\n";
    for (const auto& [k, v] : m_requests)
        o << "textond_http_requests_total{route=\"" << esc(k[0]) << "\",method=\"" << esc(k[1])
          << "\",status=\"" << k[2] << "\"} " << v << "\n";
    o << "# HELP textond_http_request_duration_seconds Time from routing to the response "
         "being written.\n# TYPE textond_http_request_duration_seconds histogram\n";
    for (const auto& [k, h] : m_latency)
        write_histogram(o, "textond_http_request_duration_seconds",
                        "route=\"" + esc(k[0]) + "\",status=\"" + k[1] + "\"", h, kLatencyBuckets);
    o << "# HELP textond_render_seconds Noise evaluation time by backend and kind (tile, "
         "region, tileable).\n# TYPE textond_render_seconds histogram\n";
    for (const auto& [k, h] : m_render_ms)
        write_histogram(o, "textond_render_seconds",
                        "backend=\"" + esc(k[0]) + "\",kind=\"" + esc(k[1]) + "\"", h,
                        kLatencyBuckets);
    o << "# HELP textond_image_stage_seconds Where an image request's time goes: queue "
         "(waiting "
         "for a render slot), render, encode, send (response ready to its last byte handed "
         "to the socket).\n# TYPE textond_image_stage_seconds histogram\n";
    for (const char* s : {"queue", "render", "encode", "send"}) {
        auto it = m_stages.find(s);
        write_histogram(o, "textond_image_stage_seconds", std::string("stage=\"") + s + "\"",
                        it == m_stages.end() ? Histogram{} : it->second, kLatencyBuckets);
    }
}

void Metrics::write_work_locked(std::ostream& o) const {
    o << "# HELP textond_tile_cache_requests_total Image cache lookups.\n"
         "# TYPE textond_tile_cache_requests_total counter\n"
      << "textond_tile_cache_requests_total{result=\"hit\"} " << m_cache_hits << "\n"
      << "textond_tile_cache_requests_total{result=\"miss\"} " << m_cache_misses << "\n";
    o << "# HELP textond_not_admitted_total Work refused before it started: too_large (413), "
         "busy (429), rate_limited (429: the client's renders a minute), gone (the client left "
         "while it waited).\n"
         "# TYPE textond_not_admitted_total counter\n";
    for (const char* why : {"too_large", "busy", "rate_limited", "gone"}) {
        auto it = m_not_admitted.find(why);
        o << "textond_not_admitted_total{reason=\"" << why << "\"} "
          << (it == m_not_admitted.end() ? 0 : it->second) << "\n";
    }
    o << "# HELP textond_backend_info The backends serving tiles and large frames.\n"
         "# TYPE textond_backend_info gauge\n"
      << "textond_backend_info{tiles=\"" << esc(m_tiles_backend) << "\",frames=\""
      << esc(m_frames_backend) << "\"} 1\n";
    if (!m_calibration.empty()) {
        o << "# HELP textond_backend_calibration_ms What --backend auto measured at start: "
             "16 tiles of 256x256 (the CPU: divided by the tiles it renders at once) and one "
             "1920x1080 frame, per candidate backend.\n"
             "# TYPE textond_backend_calibration_ms gauge\n";
        for (const auto& f : m_calibration)
            o << "textond_backend_calibration_ms{backend=\"" << esc(f.backend)
              << "\",work=\"tiles16\"} " << f.tiles16_ms << "\n"
              << "textond_backend_calibration_ms{backend=\"" << esc(f.backend)
              << "\",work=\"hd_frame\"} " << f.hd_frame_ms << "\n";
    }
    o << "# HELP textond_abandoned_total Admitted work stopped before its end: deadline "
         "(--render-deadline-s, 503), gone (the client left during the work).\n"
         "# TYPE textond_abandoned_total counter\n"
      << "textond_abandoned_total{reason=\"deadline\"} " << m_abandoned_deadline << "\n"
      << "textond_abandoned_total{reason=\"gone\"} " << m_abandoned_gone << "\n";
    o << "# HELP textond_analyses_total Texton analyses run (joined uploads are not "
         "counted).\n# TYPE textond_analyses_total counter\n"
      << "textond_analyses_total{result=\"ok\"} " << m_analyses_ok << "\n"
      << "textond_analyses_total{result=\"error\"} " << m_analyses_failed << "\n";
    o << "# HELP textond_analysis_seconds Analysis time.\n"
         "# TYPE textond_analysis_seconds histogram\n";
    write_histogram(o, "textond_analysis_seconds", "", m_analysis_seconds, kLatencyBuckets);
}

std::string Metrics::prometheus_text() const {
    std::map<std::string, Gauge> gauges;
    std::ostringstream o;
    {
        std::lock_guard lock(m_mutex);
        gauges = m_gauges;
        write_requests_locked(o);
        write_work_locked(o);
    }
    // Gauges read outside the lock: they take other components' locks.
    for (const auto& [name, g] : gauges)
        o << "# HELP " << name << " " << g.help << "\n# TYPE " << name << " gauge\n"
          << name << " " << exact_text(g.read()) << "\n";
    return o.str();
}

} // namespace textond::app
