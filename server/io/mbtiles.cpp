#include "server/io/mbtiles.h"

#include <sqlite3.h>

namespace textond::io {

namespace {

// A prepared statement that finalizes itself.
class Statement {
public:
    Statement(sqlite3* db, const char* sql) {
        m_ok = sqlite3_prepare_v2(db, sql, -1, &m_s, nullptr) == SQLITE_OK;
    }
    ~Statement() { sqlite3_finalize(m_s); }
    Statement(const Statement&) = delete;
    Statement& operator=(const Statement&) = delete;
    bool ok() const { return m_ok; }
    sqlite3_stmt* get() const { return m_s; }

private:
    sqlite3_stmt* m_s = nullptr;
    bool m_ok = false;
};

std::int64_t tms_row(int z, std::uint32_t y) {
    return (std::int64_t{1} << z) - 1 - y;
}

const char* kSchema = R"(
CREATE TABLE IF NOT EXISTS metadata (name TEXT, value TEXT);
CREATE UNIQUE INDEX IF NOT EXISTS name ON metadata (name);
CREATE TABLE IF NOT EXISTS tiles (zoom_level INTEGER, tile_column INTEGER, tile_row INTEGER,
                                  tile_data BLOB);
CREATE UNIQUE INDEX IF NOT EXISTS tile_index ON tiles (zoom_level, tile_column, tile_row);
)";

} // namespace

Result<std::unique_ptr<Mbtiles>> Mbtiles::open_flags(const std::string& path, int flags,
                                                     bool exclusive) {
    sqlite3* db = nullptr;
    const int rc = sqlite3_open_v2(path.c_str(), &db, flags, nullptr);
    std::unique_ptr<Mbtiles> m(new Mbtiles(db, path));
    if (rc != SQLITE_OK) return m->failure("cannot open");
    sqlite3_busy_timeout(db, 1000);
    if (exclusive)
        if (auto r = m->exec("PRAGMA locking_mode = EXCLUSIVE", "locking"); !r) return r.error();
    return m;
}

Result<std::unique_ptr<Mbtiles>>
Mbtiles::create(const std::string& path, bool exclusive,
                const std::vector<std::pair<std::string, std::string>>& metadata) {
    auto m = open_flags(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, exclusive);
    if (!m) return m;
    Mbtiles& db = *m.value();
    if (auto r = db.begin(); !r) return r.error();
    if (auto r = db.exec(kSchema, "creating the MBTiles tables"); !r) return r.error();
    for (const auto& [name, value] : metadata)
        if (auto r = db.set_metadata(name, value); !r) return r.error();
    if (auto r = db.commit(); !r) return r.error();
    return m;
}

Result<std::unique_ptr<Mbtiles>> Mbtiles::open(const std::string& path, bool exclusive) {
    return open_flags(path, SQLITE_OPEN_READWRITE, exclusive);
}

Mbtiles::Mbtiles(sqlite3* db, std::string path) : m_db(db), m_path(std::move(path)) {}

Mbtiles::~Mbtiles() {
    sqlite3_close(m_db);
}

Error Mbtiles::failure(const std::string& what) const {
    const int code = m_db ? sqlite3_errcode(m_db) : SQLITE_NOMEM;
    const std::string message =
        m_path + ": " + what + ": " + (m_db ? sqlite3_errmsg(m_db) : "out of memory");
    if (code == SQLITE_FULL) return {ErrorCode::no_space, message};
    if (code == SQLITE_BUSY || code == SQLITE_LOCKED)
        return {ErrorCode::unavailable, m_path + ": in use by another process (another export?)"};
    if (code == SQLITE_NOTADB || code == SQLITE_CORRUPT) return {ErrorCode::unprocessable, message};
    return {ErrorCode::io, message};
}

Result<bool> Mbtiles::exec(const char* sql, const char* what) {
    if (sqlite3_exec(m_db, sql, nullptr, nullptr, nullptr) != SQLITE_OK) return failure(what);
    return true;
}

Result<std::string> Mbtiles::metadata(const std::string& name) const {
    Statement s(m_db, "SELECT value FROM metadata WHERE name = ?");
    if (!s.ok()) return failure("reading metadata");
    sqlite3_bind_text(s.get(), 1, name.c_str(), -1, SQLITE_TRANSIENT);
    const int rc = sqlite3_step(s.get());
    if (rc == SQLITE_DONE) return make_error(ErrorCode::not_found, "no metadata " + name);
    if (rc != SQLITE_ROW) return failure("reading metadata");
    const auto* text = sqlite3_column_text(s.get(), 0);
    return std::string(text ? reinterpret_cast<const char*>(text) : "");
}

Result<bool> Mbtiles::set_metadata(const std::string& name, const std::string& value) {
    Statement s(m_db, "INSERT OR REPLACE INTO metadata (name, value) VALUES (?, ?)");
    if (!s.ok()) return failure("writing metadata");
    sqlite3_bind_text(s.get(), 1, name.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(s.get(), 2, value.c_str(), -1, SQLITE_TRANSIENT);
    if (sqlite3_step(s.get()) != SQLITE_DONE) return failure("writing metadata " + name);
    return true;
}

Result<bool> Mbtiles::put(int z, std::uint32_t x, std::uint32_t y, const std::string& bytes) {
    Statement s(m_db, "INSERT OR REPLACE INTO tiles (zoom_level, tile_column, tile_row, tile_data) "
                      "VALUES (?, ?, ?, ?)");
    if (!s.ok()) return failure("writing a tile");
    sqlite3_bind_int(s.get(), 1, z);
    sqlite3_bind_int64(s.get(), 2, x);
    sqlite3_bind_int64(s.get(), 3, tms_row(z, y));
    sqlite3_bind_blob64(s.get(), 4, bytes.data(), bytes.size(), SQLITE_STATIC);
    if (sqlite3_step(s.get()) != SQLITE_DONE) return failure("writing a tile");
    return true;
}

Result<std::string> Mbtiles::get(int z, std::uint32_t x, std::uint32_t y) const {
    Statement s(m_db, "SELECT tile_data FROM tiles WHERE zoom_level = ? AND tile_column = ? AND "
                      "tile_row = ?");
    if (!s.ok()) return failure("reading a tile");
    sqlite3_bind_int(s.get(), 1, z);
    sqlite3_bind_int64(s.get(), 2, x);
    sqlite3_bind_int64(s.get(), 3, tms_row(z, y));
    const int rc = sqlite3_step(s.get());
    if (rc == SQLITE_DONE)
        return make_error(ErrorCode::not_found, "no tile " + std::to_string(z) + "/" +
                                                    std::to_string(x) + "/" + std::to_string(y));
    if (rc != SQLITE_ROW) return failure("reading a tile");
    const auto* data = static_cast<const char*>(sqlite3_column_blob(s.get(), 0));
    return std::string(data ? data : "",
                       static_cast<std::size_t>(sqlite3_column_bytes(s.get(), 0)));
}

Result<std::vector<Mbtiles::Key>> Mbtiles::keys() const {
    Statement s(m_db, "SELECT zoom_level, tile_column, tile_row, length(tile_data) FROM tiles "
                      "ORDER BY zoom_level, tile_column, tile_row");
    if (!s.ok()) return failure("listing tiles");
    std::vector<Key> keys;
    int rc;
    while ((rc = sqlite3_step(s.get())) == SQLITE_ROW) {
        const int z = sqlite3_column_int(s.get(), 0);
        const std::int64_t row = sqlite3_column_int64(s.get(), 2);
        if (z < 0 || z > 30 || row < 0 || row > tms_row(z, 0))
            return make_error(ErrorCode::unprocessable, m_path + ": a tile outside its zoom");
        keys.push_back({z, static_cast<std::uint32_t>(sqlite3_column_int64(s.get(), 1)),
                        static_cast<std::uint32_t>(tms_row(z, static_cast<std::uint32_t>(row))),
                        static_cast<std::uint32_t>(sqlite3_column_int64(s.get(), 3))});
    }
    if (rc != SQLITE_DONE) return failure("listing tiles");
    return keys;
}

Result<bool> Mbtiles::begin() {
    return exec("BEGIN IMMEDIATE", "starting a transaction");
}
Result<bool> Mbtiles::commit() {
    return exec("COMMIT", "committing");
}

Result<bool> Mbtiles::close() {
    const int rc = sqlite3_close(m_db);
    if (rc != SQLITE_OK) return failure("closing");
    m_db = nullptr;
    return true;
}

} // namespace textond::io
