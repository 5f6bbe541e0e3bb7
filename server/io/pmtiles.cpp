#include "server/io/pmtiles.h"

#include "server/io/atomic_file.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace textond::io::pmtiles {

namespace {

void put_varint(std::string& out, std::uint64_t v) {
    while (v >= 0x80) {
        out.push_back(static_cast<char>((v & 0x7f) | 0x80));
        v >>= 7;
    }
    out.push_back(static_cast<char>(v));
}

void put_le(std::string& out, std::uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

// 1e-7 degrees, as the header keeps positions.
std::int32_t e7(double degrees) {
    return static_cast<std::int32_t>(std::lround(degrees * 1e7));
}

void put_position(std::string& out, double lon, double lat) {
    put_le(out, static_cast<std::uint32_t>(e7(lon)), 4);
    put_le(out, static_cast<std::uint32_t>(e7(lat)), 4);
}

// Leaves of `leaf_size` entries each, and the root that points at them (run length 0).
Directories roots_and_leaves(const std::vector<Entry>& entries, std::size_t leaf_size) {
    Directories d;
    std::vector<Entry> root;
    for (std::size_t i = 0; i < entries.size(); i += leaf_size) {
        const std::size_t end = std::min(entries.size(), i + leaf_size);
        const std::string leaf = serialize_directory(
            std::vector<Entry>(entries.begin() + static_cast<std::ptrdiff_t>(i),
                               entries.begin() + static_cast<std::ptrdiff_t>(end)));
        root.push_back(
            {entries[i].tile_id, d.leaves.size(), static_cast<std::uint32_t>(leaf.size()), 0});
        d.leaves += leaf;
    }
    d.root = serialize_directory(root);
    return d;
}

} // namespace

std::uint64_t tile_id(int z, std::uint32_t x, std::uint32_t y) {
    std::uint64_t id = ((std::uint64_t{1} << (2 * z)) - 1) / 3;
    std::uint64_t tx = x, ty = y;
    for (std::uint64_t s = z > 0 ? std::uint64_t{1} << (z - 1) : 0; s > 0; s >>= 1) {
        const std::uint64_t rx = (tx & s) ? 1 : 0, ry = (ty & s) ? 1 : 0;
        id += s * s * ((3 * rx) ^ ry);
        if (ry == 0) { // rotate the quadrant (only the bits below s matter from here on)
            if (rx == 1) {
                tx = s - 1 - tx;
                ty = s - 1 - ty;
            }
            std::swap(tx, ty);
        }
    }
    return id;
}

std::string serialize_directory(const std::vector<Entry>& entries) {
    std::string out;
    put_varint(out, entries.size());
    std::uint64_t last = 0;
    for (const Entry& e : entries) {
        put_varint(out, e.tile_id - last);
        last = e.tile_id;
    }
    for (const Entry& e : entries) put_varint(out, e.run_length);
    for (const Entry& e : entries) put_varint(out, e.length);
    for (std::size_t i = 0; i < entries.size(); ++i) {
        // 0: right after the previous entry (spec §3.4), else the offset plus one
        const bool follows =
            i > 0 && entries[i].offset == entries[i - 1].offset + entries[i - 1].length;
        put_varint(out, follows ? 0 : entries[i].offset + 1);
    }
    return out;
}

Directories build_directories(const std::vector<Entry>& entries) {
    Directories d;
    d.root = serialize_directory(entries);
    if (d.root.size() <= static_cast<std::size_t>(kRootBytes)) return d;
    // as the reference writer (go-pmtiles) does: leaves of at least 4096 entries, grown by 20%
    // until the root fits
    double leaf_size = std::max(4096.0, static_cast<double>(entries.size()) / 3500.0);
    for (;;) {
        d = roots_and_leaves(entries, static_cast<std::size_t>(leaf_size));
        if (d.root.size() <= static_cast<std::size_t>(kRootBytes)) return d;
        leaf_size *= 1.2;
    }
}

std::string serialize_header(const Header& h) {
    std::string out = "PMTiles";
    out.push_back(3);
    for (std::uint64_t v : {h.root_offset, h.root_length, h.metadata_offset, h.metadata_length,
                            h.leaves_offset, h.leaves_length, h.data_offset, h.data_length,
                            h.addressed_tiles, h.tile_entries, h.tile_contents})
        put_le(out, v, 8);
    out.push_back(h.clustered ? 1 : 0);
    out.push_back(static_cast<char>(h.internal_compression));
    out.push_back(static_cast<char>(h.tile_compression));
    out.push_back(static_cast<char>(h.tile_type));
    out.push_back(static_cast<char>(h.min_zoom));
    out.push_back(static_cast<char>(h.max_zoom));
    put_position(out, h.min_lon, h.min_lat);
    put_position(out, h.max_lon, h.max_lat);
    out.push_back(static_cast<char>(h.center_zoom));
    put_position(out, h.center_lon, h.center_lat);
    return out;
}

Result<bool> write_archive(const std::string& path, Header header, const std::string& metadata,
                           const std::vector<Tile>& tiles,
                           const std::function<Result<std::string>(std::size_t)>& tile_bytes) {
    std::vector<std::uint64_t> ids(tiles.size());
    for (std::size_t i = 0; i < tiles.size(); ++i) {
        const Tile& t = tiles[i];
        if (t.z < 0 || t.z > kMaxZoom || t.x >> t.z != 0 || t.y >> t.z != 0)
            return make_error(ErrorCode::invalid_argument, "tile outside its zoom's grid");
        ids[i] = tile_id(t.z, t.x, t.y);
    }
    std::vector<std::size_t> order(tiles.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(),
              [&](std::size_t a, std::size_t b) { return ids[a] < ids[b]; });
    std::vector<Entry> entries;
    entries.reserve(tiles.size());
    std::uint64_t offset = 0;
    for (std::size_t i : order) {
        if (!entries.empty() && entries.back().tile_id == ids[i])
            return make_error(ErrorCode::invalid_argument, "the same tile twice in an archive");
        entries.push_back({ids[i], offset, tiles[i].length, 1});
        offset += tiles[i].length;
    }
    const Directories dirs = build_directories(entries);
    header.root_offset = kHeaderBytes;
    header.root_length = dirs.root.size();
    header.metadata_offset = header.root_offset + header.root_length;
    header.metadata_length = metadata.size();
    header.leaves_offset = header.metadata_offset + header.metadata_length;
    header.leaves_length = dirs.leaves.size();
    header.data_offset = header.leaves_offset + header.leaves_length;
    header.data_length = offset;
    header.addressed_tiles = header.tile_entries = header.tile_contents = tiles.size();
    header.clustered = true;
    header.internal_compression = Compression::none;

    auto file = AtomicFile::create(path);
    if (!file) return file.error();
    AtomicFile& out = *file.value();
    for (const std::string& part : {serialize_header(header), dirs.root, metadata, dirs.leaves})
        if (auto w = out.write(part); !w) return w.error();
    for (std::size_t i : order) {
        auto bytes = tile_bytes(i);
        if (!bytes) return bytes.error();
        if (bytes.value().size() != tiles[i].length)
            return make_error(ErrorCode::internal, "a tile changed length while archived");
        if (auto w = out.write(bytes.value()); !w) return w.error();
    }
    return out.commit();
}

} // namespace textond::io::pmtiles
