#pragma once
// Everything `textond serve` can be told, with the embedded defaults the README promises: a
// local data directory, the `auto` backend (a GPU through EGL when there is one, else the CPU),
// loopback on port 8080. Set by flags or TEXTOND_* environment variables
// (server/cli/serve_command).
#include "api/requests.h"
#include "render/backend_factory.h"
#include "server/app/url_signing.h"
#include "server/http/imports.h"

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace textond::http {

struct ServeConfig {
    std::string host = "127.0.0.1";
    int port = 8080; // 0 = any free port (tests)
    std::string data_dir = "./data";
    // Shared texton store for replicas (redis://...); empty = the data directory alone. With
    // one, the data directory is a read-through cache of it (server/store/texton_store.h).
    std::string store_url;
    int store_timeout_ms = 1000; // connect and command timeout
    int store_recheck_s = 30;    // how stale a local copy may get (deletes reach other replicas)
    int meta_cache = 10000;      // textons whose metadata stays in memory (most recently used)
    render::BackendKind backend = render::BackendKind::automatic;
    std::string public_url; // base of TileJSON URLs; empty = from the request's Host header

    // cpp-httplib serves one connection per worker thread for as long as it is kept alive, so
    // the pool must cover the connections expected at once; renders are bounded separately.
    int http_threads = 128;     // connection threads kept
    int max_connections = 1024; // connection threads at most (more are started on demand)
    // Renders at once; 0 = one per core, plus --gpu-batch-tiles more a GL lane when tiles and
    // frames both go to a GL backend (a slot then mostly waits for its batch).
    int render_slots = 0;
    int gpu_batch_tiles = 64;    // GL: windows gathered into one batch at most
    int gpu_batch_wait_us = 200; // GL: how long a batch waits for more once one is queued
    int gpu_batch_ms = 25;       // GL: measured work a batch holds at most (one window at least)
    int gpu_lanes = 0;           // GL: batch workers, a context each; 0 = 3 on a GPU, 1 in software
    int analysis_workers = 1;    // analyses at once (each uses every core)
    int analysis_queue = 4;      // waiting analyses before 429
    int read_timeout_s = 30;
    int write_timeout_s = 30;
    int keep_alive_max = 1000; // requests per connection
    int keep_alive_timeout_s = 5;
    int listen_backlog = 1024; // pending connections (the kernel caps it at net.core.somaxconn)
    // Per request (server/http/connection.h): the request line and headers in bytes, lines and
    // time from their first byte, and the body's time.
    std::size_t max_header_bytes = 64 * 1024;
    int max_headers = 100;
    int header_timeout_s = 10;
    int body_timeout_s = 120;
    // Admission (server/http/gate.h, server/app/work_cost.h): how long a request may wait for a
    // render slot, how many may wait, the most estimated CPU seconds one request may cost, and the
    // request bodies held in memory by all requests together.
    int queue_timeout_ms = 10'000;
    // Renders (cache misses) a client may start a minute, and in one burst (rate_limiter.h);
    // 0: no limit.
    int render_rate = 0;
    int render_burst = 20;
    int render_queue = 1024;
    double max_request_cpu_s = 20;
    // Admitted work is abandoned this long after it started (503 deadline_exceeded), and as soon
    // as its client leaves (render/cancel.h).
    int render_deadline_s = 60;
    std::size_t body_budget_bytes = std::size_t{256} << 20;

    std::size_t cache_bytes = std::size_t{256} << 20;
    std::size_t table_cache_bytes = std::size_t{256} << 20; // render/table_budget.h
    std::size_t max_upload_bytes = std::size_t{32} << 20;
    std::uint64_t max_pixels = 16'777'216; // exemplar pixels, checked from the header
    // OpenEXR is opt-in (--formats ...,openexr): the fuzzer found three ways for a few kB of
    // EXR to overflow or exhaust memory in Debian's OpenEXR/OpenImageIO (tests/fuzz/regressions);
    // they are mitigated, but it kept finding more in every run of ten minutes.
    std::vector<std::string> formats = {"png", "jpeg", "tiff", "bmp"};
    api::Limits limits;
    // zlib level of PNG images. Noise hardly compresses: level 1 saves 14% of the bytes of an
    // 8-bit tile for 8x the encoding time (`textond bench tile`; api/README.md,
    // "--png-compression"), so the default stores.
    int png_compression = 0;

    std::string api_key; // empty: POST and DELETE are open
    // Image URLs signed with this key (server/app/url_signing.h); empty: unsigned URLs.
    std::string url_signing_key;
    Presets presets;               // non-empty: image URLs name one of these parameter sets
    std::string cors_origin = "*"; // "" disables CORS; else "*" or a comma-separated list
    std::string web_dir; // the page served at / (index.html, app.js, leaflet/); empty = built-in
    std::string log_level = "info";
    bool access_log = true;
};

// "a, b,c" -> {"a", "b", "c"}: spaces trimmed, empty items dropped (--formats, --cors-origin).
inline std::vector<std::string> split_list(std::string_view s) {
    std::vector<std::string> out;
    std::size_t pos = 0;
    while (pos <= s.size()) {
        std::size_t end = s.find(',', pos);
        if (end == std::string_view::npos) end = s.size();
        std::string item(s.substr(pos, end - pos));
        item.erase(0, item.find_first_not_of(' '));
        item.erase(item.find_last_not_of(' ') + 1);
        if (!item.empty()) out.push_back(item);
        pos = end + 1;
    }
    return out;
}

} // namespace textond::http
