#include "tests/support/pmtiles_reader.h"

#include <stdexcept>
#include <vector>

namespace textond::test {

namespace {

std::uint64_t le(const std::string& b, std::size_t at, int n) {
    if (at + static_cast<std::size_t>(n) > b.size()) throw std::runtime_error("header cut short");
    std::uint64_t v = 0;
    for (int i = n - 1; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(b[at + i]);
    return v;
}

std::uint64_t varint(const std::string& b, std::size_t& pos, std::size_t end) {
    std::uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
        if (pos >= end) throw std::runtime_error("directory cut short");
        const auto c = static_cast<unsigned char>(b[pos++]);
        v |= std::uint64_t{c & 0x7fu} << shift;
        if (c < 0x80) return v;
    }
    throw std::runtime_error("varint too long");
}

struct Entry {
    std::uint64_t id, offset, length, run;
};

std::vector<Entry> directory(const std::string& b, std::uint64_t at, std::uint64_t length) {
    if (at + length > b.size()) throw std::runtime_error("directory past the end");
    std::size_t pos = at;
    const std::size_t end = at + length;
    std::vector<Entry> e(varint(b, pos, end));
    std::uint64_t id = 0;
    for (auto& x : e) x.id = id += varint(b, pos, end);
    for (auto& x : e) x.run = varint(b, pos, end);
    for (auto& x : e) x.length = varint(b, pos, end);
    for (std::size_t i = 0; i < e.size(); ++i) {
        const std::uint64_t v = varint(b, pos, end);
        if (v == 0 && i == 0) throw std::runtime_error("first offset coded as 'follows'");
        e[i].offset = v == 0 ? e[i - 1].offset + e[i - 1].length : v - 1;
    }
    if (pos != end) throw std::runtime_error("bytes left after a directory");
    return e;
}

void walk(const std::string& b, PmtilesFile& f, std::uint64_t at, std::uint64_t length, int depth) {
    if (depth > 3) throw std::runtime_error("directories nested deeper than the spec allows");
    for (const Entry& e : directory(b, at, length)) {
        if (e.run == 0) {
            ++f.leaf_directories;
            walk(b, f, f.leaves_offset + e.offset, e.length, depth + 1);
            continue;
        }
        if (f.data_offset + e.offset + e.length > f.data_offset + f.data_length)
            throw std::runtime_error("a tile past the tile data");
        for (std::uint64_t k = 0; k < e.run; ++k)
            f.tiles[zxy_of_tile_id(e.id + k)] = b.substr(f.data_offset + e.offset, e.length);
    }
}

} // namespace

std::tuple<int, std::uint32_t, std::uint32_t> zxy_of_tile_id(std::uint64_t id) {
    int z = 0;
    std::uint64_t acc = 0;
    while (acc + (std::uint64_t{1} << (2 * z)) <= id) acc += std::uint64_t{1} << (2 * z++);
    std::uint64_t t = id - acc, x = 0, y = 0;
    for (std::uint64_t s = 1; s < (std::uint64_t{1} << z); s *= 2) {
        const std::uint64_t rx = 1 & (t / 2), ry = 1 & (t ^ rx);
        if (ry == 0) {
            if (rx == 1) {
                x = s - 1 - x;
                y = s - 1 - y;
            }
            std::swap(x, y);
        }
        x += s * rx;
        y += s * ry;
        t /= 4;
    }
    return {z, static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y)};
}

PmtilesFile read_pmtiles(const std::string& b) {
    PmtilesFile f;
    try {
        f.magic = b.substr(0, 7);
        f.version = static_cast<int>(le(b, 7, 1));
        std::uint64_t* u64[] = {&f.root_offset,     &f.root_length,   &f.metadata_offset,
                                &f.metadata_length, &f.leaves_offset, &f.leaves_length,
                                &f.data_offset,     &f.data_length,   &f.addressed_tiles,
                                &f.tile_entries,    &f.tile_contents};
        for (int i = 0; i < 11; ++i) *u64[i] = le(b, 8 + 8 * i, 8);
        int* u8[] = {&f.clustered,        &f.internal_compression,
                     &f.tile_compression, &f.tile_type,
                     &f.min_zoom,         &f.max_zoom};
        for (int i = 0; i < 6; ++i) *u8[i] = static_cast<int>(le(b, 96 + i, 1));
        std::int32_t* pos[] = {&f.min_lon_e7, &f.min_lat_e7, &f.max_lon_e7, &f.max_lat_e7};
        for (int i = 0; i < 4; ++i) *pos[i] = static_cast<std::int32_t>(le(b, 102 + 4 * i, 4));
        f.center_zoom = static_cast<int>(le(b, 118, 1));
        f.center_lon_e7 = static_cast<std::int32_t>(le(b, 119, 4));
        f.center_lat_e7 = static_cast<std::int32_t>(le(b, 123, 4));
        f.metadata = b.substr(f.metadata_offset, f.metadata_length);
        walk(b, f, f.root_offset, f.root_length, 0);
        f.ok = true;
    } catch (const std::exception& e) {
        f.error = e.what();
    }
    return f;
}

} // namespace textond::test
