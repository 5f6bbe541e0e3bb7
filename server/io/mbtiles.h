#pragma once
// MBTiles 1.3 (github.com/mapbox/mbtiles-spec, 1.3/spec.md) through SQLite: a `metadata` table of
// name/value rows and a `tiles` table whose rows count from the bottom (TMS: tile_row =
// 2^z - 1 - y). Callers speak XYZ (y down, as the map routes do); the flip is done here.
// `textond export` also uses it as its resumable spool: each committed batch survives a kill.
#include "core/result.h"

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

struct sqlite3;

namespace textond::io {

class Mbtiles {
public:
    // `exclusive`: the first write locks the database until close, so a second process is told
    // at once (unavailable, "in use by another process") instead of interleaving its writes.
    // A new database at `path` (absent, or an empty file) with the spec's schema and `metadata`,
    // all in one transaction.
    static Result<std::unique_ptr<Mbtiles>>
    create(const std::string& path, bool exclusive = false,
           const std::vector<std::pair<std::string, std::string>>& metadata = {});
    // An existing database, changed in nothing until written to.
    static Result<std::unique_ptr<Mbtiles>> open(const std::string& path, bool exclusive = false);
    ~Mbtiles();
    Mbtiles(const Mbtiles&) = delete;
    Mbtiles& operator=(const Mbtiles&) = delete;

    // The value of a metadata row; not_found without one.
    Result<std::string> metadata(const std::string& name) const;
    Result<bool> set_metadata(const std::string& name, const std::string& value);

    struct Key {
        int z;
        std::uint32_t x, y; // XYZ
        std::uint32_t length = 0;
    };
    Result<bool> put(int z, std::uint32_t x, std::uint32_t y, const std::string& bytes);
    Result<std::string> get(int z, std::uint32_t x, std::uint32_t y) const;
    // Every stored tile with its length, in (z, x, y) order.
    Result<std::vector<Key>> keys() const;

    // Writes between begin and commit land together or not at all.
    Result<bool> begin();
    Result<bool> commit();
    // Closes the database (its journal folded in); the object is unusable after.
    Result<bool> close();

private:
    explicit Mbtiles(sqlite3* db, std::string path);
    static Result<std::unique_ptr<Mbtiles>> open_flags(const std::string& path, int flags,
                                                       bool exclusive);
    Result<bool> exec(const char* sql, const char* what);
    Error failure(const std::string& what) const;
    sqlite3* m_db = nullptr;
    std::string m_path;
};

} // namespace textond::io
