// POST/GET/DELETE /v1/textons...: uploads (single flight on a bounded pool), metadata, the
// texton's files, listing.
#include "server/http/texton_routes.h"

#include "api/requests.h"
#include "core/texton_analysis.h"
#include "server/http/auth.h"
#include "server/http/connection.h"
#include "server/http/request_context.h"
#include "server/http/responses.h"
#include "server/io/image_io.h"
#include "server/io/texton_file.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace textond::http {

namespace {

const char* kLinkTemplates[][2] = {
    {"self", ""},
    {"status", "/status"},
    {"texton_png", "/texton.png"},
    {"texton_exr", "/texton.exr"},
    {"texton_v1", "/texton.texton"},
    {"exemplar_png", "/exemplar.png"},
    {"spectrum_png", "/spectrum.png"},
    {"tilejson", "/tilejson.json"},
    {"tiles", "/tiles/{z}/{x}/{y}.png"},
    {"region", "/region.png"},
    {"tileable", "/tileable.png"},
};

// A view of the coefficients people can look at: mid-grey is zero, full scale the largest
// magnitude of any channel (the raw values are in texton.exr). A material set's maps stand side
// by side in RGB, in their channel order (a PNG holds at most 4 channels; a set up to 8).
core::Image visualise(const core::Texton& t) {
    float peak = 0;
    for (float v : t.alpha.data) peak = std::max(peak, std::abs(v));
    const float scale = peak > 0 ? 0.5f / peak : 0.0f;
    if (t.maps.empty()) {
        core::Image out(t.size, t.size, t.channels);
        for (std::size_t k = 0; k < out.data.size(); ++k)
            out.data[k] = 0.5f + t.alpha.data[k] * scale;
        return out;
    }
    core::Image out(t.size * static_cast<int>(t.maps.size()), t.size, 3);
    for (std::size_t i = 0; i < t.maps.size(); ++i) {
        const core::TextonMap& m = t.maps[i];
        for (int c = 0; c < 3; ++c)
            for (int y = 0; y < t.size; ++y)
                for (int x = 0; x < t.size; ++x)
                    out.at(c, static_cast<int>(i) * t.size + x, y) =
                        0.5f + t.alpha.at(m.first + std::min(c, m.channels - 1), x, y) * scale;
    }
    return out;
}

bool is_map_field(const std::string& name) {
    for (const char* n : core::kMapNames)
        if (name == n) return true;
    return name == core::kNormalMap;
}

// A material set's map parts (albedo, height, ...), or an error; none for a single exemplar.
std::optional<api::ApiError> map_parts(const std::vector<httplib::MultipartFormData>& parts,
                                       std::vector<TextonService::MapUpload>& maps) {
    for (const auto& part : parts) {
        if (!is_map_field(part.name)) continue;
        if (part.name == core::kNormalMap)
            return api::ApiError{"invalid_parameter",
                                 "a set's normal map is made from its height map exactly "
                                 "(map=normal on the image endpoints): upload 'height', not "
                                 "'normal'"};
        for (const auto& m : maps)
            if (m.name == part.name)
                return api::ApiError{"invalid_parameter",
                                     "more than one '" + part.name + "' field in the form"};
        if (part.content.empty())
            return api::ApiError{"empty_body", "the '" + part.name + "' field is empty"};
        maps.push_back({part.name, part.content});
    }
    for (const auto& part : parts)
        if (!maps.empty() && part.name == "exemplar")
            return api::ApiError{"invalid_parameter",
                                 "a form has either an 'exemplar' or a material set's maps "
                                 "(albedo, height, roughness, ao, metallic), not both"};
    return std::nullopt;
}

// The one `exemplar` part of a form; the other parts are analysis fields.
std::optional<api::ApiError> exemplar_part(const std::vector<httplib::MultipartFormData>& parts,
                                           api::Query& fields, std::string_view& bytes) {
    bytes = {};
    for (const auto& part : parts) {
        if (is_map_field(part.name)) continue;
        if (part.name != "exemplar") {
            fields.emplace(part.name, part.content);
            continue;
        }
        if (!bytes.empty())
            return api::ApiError{"invalid_parameter", "more than one 'exemplar' field in the form"};
        bytes = part.content;
        if (bytes.empty()) return api::ApiError{"empty_body", "the 'exemplar' field is empty"};
    }
    if (bytes.empty())
        return api::ApiError{"missing_exemplar",
                             "multipart upload without an 'exemplar' file field"};
    return std::nullopt;
}

nlohmann::json texton_json(const api::TextonMeta& meta) {
    nlohmann::json j = meta;
    if (meta.timings) j["analysis_ms"] = meta.timings->total_ms;
    j["verdict"] = meta.verdict();
    const std::string base = "/v1/textons/" + meta.id;
    nlohmann::json links;
    for (const auto& [name, suffix] : kLinkTemplates) links[name] = base + suffix;
    j["links"] = links;
    return j;
}

} // namespace

namespace {
std::vector<std::string_view> map_bytes(const std::vector<TextonService::MapUpload>& maps) {
    std::vector<std::string_view> out;
    out.reserve(maps.size());
    for (const auto& m : maps) out.push_back(m.bytes);
    return out;
}
} // namespace

TextonRoutes::TextonRoutes(const ServeConfig& config, TextonStore& store, TextonService& textons,
                           AnalysisPool& pool, ImageCache& cache, Gate& gate,
                           const std::atomic<bool>& stopping)
    : m_config(config), m_store(store), m_textons(textons), m_pool(pool),
      m_board(pool, store.shared(), &TextonRoutes::job_status), m_cache(cache), m_gate(gate),
      m_stopping(stopping) {}

nlohmann::json TextonRoutes::job_status(const AnalysisJob& job) {
    const auto [done, total] = job.progress();
    nlohmann::json body = {{"id", job.id()},
                           {"state", to_string(job.state())},
                           {"progress", {{"done", done}, {"total", total}}},
                           {"links", {{"self", "/v1/textons/" + job.id()}}}};
    if (job.state() == AnalysisJob::State::failed) {
        const api::ApiError e = to_api_error(job.wait().error());
        body["error"] = {{"code", e.code}, {"message", e.message}};
    }
    return body;
}

void TextonRoutes::upload(Req req, Res res, const httplib::ContentReader& reader) {
    set_route("/v1/textons");
    if (!authorised(m_config.api_key, req, res)) return;
    if (m_stopping) {
        res.set_header("Retry-After", "5");
        return send_error(res, {"shutting_down", "the service is shutting down"});
    }
    // The body is read here rather than by cpp-httplib, which would parse a body sent as
    // application/x-www-form-urlencoded (curl --data-binary's default) as form fields.
    // Every byte is counted here, chunked or not: cpp-httplib checks its limit against
    // Content-Length alone (a chunked 300 MB upload was read whole into memory).
    Body counted(m_gate.bodies());
    std::vector<httplib::MultipartFormData> parts;
    const bool multipart = req.is_multipart_form_data();
    const std::size_t limit = m_config.max_upload_bytes;
    if (auto e = multipart ? read_parts(reader, limit, res.status, counted, parts)
                           : read_body(reader, limit, counted)) {
        if (e->code == "overloaded") res.set_header("Retry-After", "1");
        return send_error(res, *e);
    }
    // Parameters come from the query and, for multipart uploads, from the other form fields.
    api::Query fields = req.params;
    std::string_view bytes = counted.bytes;
    std::vector<TextonService::MapUpload> maps;
    if (multipart) {
        if (auto e = map_parts(parts, maps)) return send_error(res, *e);
        if (!maps.empty()) {
            for (const auto& part : parts)
                if (!is_map_field(part.name)) fields.emplace(part.name, part.content);
        } else if (auto e = exemplar_part(parts, fields, bytes)) {
            return send_error(res, *e);
        }
    }
    core::AnalysisParams params;
    if (auto e = api::parse_analysis(fields, params)) return send_error(res, *e);
    auto lease =
        lease_decodes(res, maps.empty() ? std::vector<std::string_view>{bytes} : map_bytes(maps));
    if (!lease) return;
    if (!maps.empty()) {
        auto ingest = m_textons.ingest_set(maps, params);
        lease->reset(); // decoded, named and dropped: a queued job holds the bytes alone
        if (const auto* refused = std::get_if<TextonService::Refused>(&ingest))
            return send_refused(res, *refused);
        return send_ingested(req, res, std::get<TextonService::Ingested>(ingest));
    }
    if (bytes.empty())
        return send_error(res, {"empty_body",
                                "no exemplar: send the image as the body (Content-Type: image/*) "
                                "or as the 'exemplar' field of a multipart form"});
    auto ingest = m_textons.ingest(bytes, params);
    lease->reset();
    if (const auto* refused = std::get_if<TextonService::Refused>(&ingest))
        return send_refused(res, *refused);
    send_ingested(req, res, std::get<TextonService::Ingested>(ingest));
}

// What the decodes hold (their planes, a band of rows and the reader's own piece, from the
// headers) is reserved from the decode budget before the decode, and held until the texton's id is
// known: eight 49 KB PNGs of 4096 x 4096 sent at once are decoded within it, not all at once. What
// the decode then refuses is said by it. Null when the refusal (429) was sent.
std::optional<std::shared_ptr<BudgetLease>>
TextonRoutes::lease_decodes(Res res, const std::vector<std::string_view>& images) {
    std::size_t decoded = 0;
    io::DecodeLimits limits;
    limits.max_pixels = m_config.max_pixels;
    limits.formats = m_config.formats;
    for (const std::string_view b : images)
        if (auto h = io::image_header_memory(b, limits)) decoded += h.value().decode_bytes;
    if (decoded <= (std::size_t{1} << 20)) return std::shared_ptr<BudgetLease>();
    auto lease = m_gate.lease_decode(res, decoded);
    if (!lease) return std::nullopt;
    return lease;
}

void TextonRoutes::send_refused(Res res, const TextonService::Refused& r) {
    using Stage = TextonService::Refused::Stage;
    const Error& err = r.error;
    switch (r.stage) {
    case Stage::busy:
        return m_gate.refuse(res, r.admit, "every decoder is busy; retry shortly");
    case Stage::decode:
        return send_error(res, content_error(err, "invalid_image"));
    case Stage::check:
        return send_error(res, {"exemplar_too_small", err.message});
    case Stage::size:
        return send_error(res, {"map_size_mismatch", err.message});
    case Stage::work:
        return send_error(res, {"work_too_large", err.message});
    case Stage::lookup:
        break;
    }
    send_error(res, to_api_error(err));
}

void TextonRoutes::send_ingested(Req req, Res res, const TextonService::Ingested& in) {
    if (in.known) return send_json(res, 200, texton_json(*in.known));
    const AnalysisPool::Submitted& submitted = in.submitted;
    if (!submitted.job) return m_gate.pool_full(res, m_pool);
    const std::string& id = in.id;
    const std::string status_url = "/v1/textons/" + id + "/status";
    // RFC 7240: a client that prefers not to wait gets 202 and polls the status URL.
    const bool polls = req.get_header_value("Prefer").find("respond-async") != std::string::npos;
    m_pool.attach(submitted.job, polls);
    if (polls) {
        m_board.publish(submitted.job); // its status may be asked of another replica at once
        res.set_header("Location", status_url);
        res.set_header("Preference-Applied", "respond-async");
        const auto [done, total] = submitted.job->progress();
        return send_json(res, 202,
                         {{"id", id},
                          {"state", to_string(submitted.job->state())},
                          {"progress", {{"done", done}, {"total", total}}},
                          {"links", {{"status", status_url}, {"self", "/v1/textons/" + id}}}});
    }
    // Waiting on the connection: a client that hangs up before its analysis starts takes it out
    // of the queue (unless another client waits for the same texton).
    const ConnectionStream* conn = current_connection();
    const Result<AnalysisOutcome>* done = nullptr;
    while (!(done = submitted.job->wait_for(std::chrono::milliseconds(100))))
        if (conn && conn->client_gone()) {
            m_pool.leave(submitted.job);
            return send_error(res, {"client_gone", "the client left before its analysis ended"});
        }
    m_pool.leave(submitted.job); // answered: no longer waiting
    const Result<AnalysisOutcome>& outcome = *done;
    if (!outcome) {
        const Error& err = outcome.error();
        return send_error(
            res,
            to_api_error(err, err.code == ErrorCode::invalid_argument ? "invalid_parameter" : ""));
    }
    const bool created = outcome.value().created && !submitted.joined;
    if (created) res.set_header("Location", "/v1/textons/" + id);
    send_json(res, created ? 201 : 200, texton_json(outcome.value().meta));
}

void TextonRoutes::get(Req req, Res res) {
    set_route("/v1/textons/{id}");
    const std::string id = req.matches[1].str();
    if (auto e = api::check_texton_id(id)) return send_error(res, *e);
    auto meta = m_store.find(id);
    if (!meta) return send_error(res, to_api_error(meta.error()));
    // Not kept by caches (the edge's included): after a DELETE the metadata is gone at once.
    send_json(res, 200, texton_json(meta.value()), "no-cache");
}

void TextonRoutes::status(Req req, Res res) {
    set_route("/v1/textons/{id}/status");
    const std::string id = req.matches[1].str();
    if (auto e = api::check_texton_id(id)) return send_error(res, *e);
    if (!takes_no_query(req, res)) return;
    const std::string self = "/v1/textons/" + id;
    // Stored: done. Not found: the pool's job, if any. Any other error (the shared store down)
    // is the store's answer.
    auto stored = [&]() -> bool {
        auto meta = m_store.find(id);
        if (meta) {
            const int n = meta.value().iterations;
            send_json(res, 200,
                      {{"id", id},
                       {"state", "done"},
                       {"progress", {{"done", n}, {"total", n}}},
                       {"links", {{"self", self}}}});
            return true;
        }
        if (meta.error().code == ErrorCode::not_found) return false;
        send_error(res, to_api_error(meta.error()));
        return true;
    };
    if (stored()) return;
    // This replica's job, or another's as that replica answers for it (server/app/job_board.h).
    nlohmann::json body;
    if (auto job = m_pool.find(id))
        body = job_status(*job);
    else if (auto elsewhere = m_board.find(id))
        body = std::move(*elsewhere);
    else
        return send_error(res, {"not_found", "no texton or analysis " + id});
    // A job done since the first look has stored its texton; one the store no longer has was
    // deleted after its analysis (a finished job is remembered a while, here and on the board).
    if (body.value("state", "") == "done") {
        if (stored()) return;
        return send_error(res, {"not_found", "texton " + id + " was deleted after its analysis"});
    }
    send_json(res, 200, body);
}

void TextonRoutes::file(Req req, Res res) {
    set_route("/v1/textons/{id}/texton.{ext}");
    const std::string id = req.matches[1].str(), ext = req.matches[2].str();
    if (auto e = api::check_texton_id(id)) return send_error(res, *e);
    if (!takes_no_query(req, res)) return;
    if (auto found = m_store.find(id); !found) return send_error(res, to_api_error(found.error()));
    if (ext == "exr") {
        auto bytes = m_store.file_bytes(id);
        if (!bytes) return send_error(res, to_api_error(bytes.error()));
        res.set_header("Cache-Control", kDeletableFor);
        res.set_header("Content-Disposition", "inline; filename=\"" + id.substr(0, 12) + ".exr\"");
        fit_ranges(res, bytes.value().size());
        return res.set_content(bytes.value(), "image/x-exr");
    }
    auto record = m_store.record(id);
    if (!record) return send_error(res, to_api_error(record.error()));
    res.set_header("Cache-Control", kDeletableFor);
    if (ext == "texton") {
        res.set_header("Content-Disposition",
                       "attachment; filename=\"" + id.substr(0, 12) + ".texton\"");
        std::string text = io::texton_v1_text(record.value(), id + ".png");
        fit_ranges(res, text.size());
        return res.set_content(text, "text/plain");
    }
    if (ext != "png")
        return send_error(res, {"invalid_format", "texton views are .png, .exr or .texton"});
    auto png = io::encode_image_memory(visualise(record.value().texton), io::Encoding::png8);
    if (!png) return send_error(res, to_api_error(png.error()));
    fit_ranges(res, png.value().size());
    res.set_content(png.value(), "image/png");
}

void TextonRoutes::remove(Req req, Res res) {
    set_route("/v1/textons/{id}");
    const std::string id = req.matches[1].str();
    if (!authorised(m_config.api_key, req, res)) return;
    if (auto e = api::check_texton_id(id)) return send_error(res, *e);
    if (!if_match_holds(req.get_header_value("If-Match"), "") && m_store.find(id, true))
        return send_error(res, no_entity_tag("texton"));
    auto r = m_store.remove(id);
    if (!r) return send_error(res, to_api_error(r.error()));
    m_cache.erase_texton(id);
    res.status = 204;
}

void TextonRoutes::list(Req req, Res res) {
    set_route("/v1/textons");
    api::ListRequest q;
    if (auto e = api::parse_list(req.params, q)) return send_error(res, *e);
    std::string resume; // the page ended early, for its byte budget: go on after this id
    const auto listed = m_store.list(q.after, q.limit + 1, &resume);
    if (!listed) return send_error(res, to_api_error(listed.error()));
    const auto total = m_store.total();
    if (!total) return send_error(res, to_api_error(total.error()));
    const std::vector<api::TextonMeta>& page = listed.value();
    nlohmann::json items = nlohmann::json::array();
    for (std::size_t i = 0; i < page.size() && static_cast<int>(i) < q.limit; ++i)
        items.push_back(texton_json(page[i]));
    nlohmann::json body = {{"items", items}, {"total", total.value()}};
    if (static_cast<int>(page.size()) > q.limit || !resume.empty()) {
        const std::string& last = static_cast<int>(page.size()) > q.limit
                                      ? page[static_cast<std::size_t>(q.limit) - 1].id
                                      : resume;
        body["next"] = "/v1/textons?limit=" + std::to_string(q.limit) + "&after=" + last;
    } else {
        body["next"] = nullptr;
    }
    send_json(res, 200, body, "no-cache");
}

void TextonRoutes::fallback(Req req, Res res) {
    set_route("/v1/textons/*");
    const std::string rest = req.matches[1];
    const std::string first = rest.substr(0, rest.find('/'));
    if (auto e = api::check_texton_id(first)) return send_error(res, *e);
    send_error(res, {"not_found", "no such endpoint under /v1/textons/" + first});
}

} // namespace textond::http
