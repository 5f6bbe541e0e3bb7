#include "server/io/image_io.h"

#include "server/io/atomic_file.h"
#include "server/io/quantise.h"
#include "server/io/sha256.h"
#include "server/io/upload_bytes.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

namespace textond::io {

namespace fs = std::filesystem;
using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

namespace {

Error unprocessable(const std::string& what) {
    return make_error(ErrorCode::unprocessable, what);
}

std::string oiio_message(const std::string& raw) {
    std::string m = raw;
    while (!m.empty() && (m.back() == '\n' || m.back() == ' ')) m.pop_back();
    std::replace(m.begin(), m.end(), '\n', ' ');
    return m.empty() ? "unknown decoder error" : m;
}

// Which channels a decode keeps, and how it reads them: the bytes it holds at once follow.
struct DecodePlan {
    std::vector<int> src;  // the kept channels' indices in the file (alpha skipped)
    int read_channels = 0; // channels 0..read_channels-1 are read (every kept one among them)
    int band = 0;          // rows read at once: 64, or a row of tiles
    std::uint64_t reader_chunk = 0; // what the reader inflates at once: a tile or strip, native
    std::uint64_t held = 0;         // the planes, the band of floats and the reader's chunk
};

DecodePlan plan_decode(const ImageSpec& spec, const DecodeLimits& limits) {
    DecodePlan p;
    int alpha = spec.alpha_channel;
    if (alpha < 0 && (spec.nchannels == 2 || spec.nchannels == 4)) alpha = spec.nchannels - 1;
    if (limits.all_channels) alpha = -1;
    const int colour_channels = spec.nchannels - (alpha >= 0 ? 1 : 0);
    const int out_channels = limits.all_channels ? spec.nchannels : colour_channels >= 3 ? 3 : 1;
    for (int c = 0; c < spec.nchannels && static_cast<int>(p.src.size()) < out_channels; ++c)
        if (c != alpha) p.src.push_back(c);
    p.read_channels = p.src.empty() ? 1 : p.src.back() + 1;
    const auto width = static_cast<std::uint64_t>(spec.width);
    const auto pixel = static_cast<std::uint64_t>(spec.pixel_bytes(true));
    if (spec.tile_width > 0) {
        p.band = std::max(1, spec.tile_height);
        p.reader_chunk = static_cast<std::uint64_t>(spec.tile_width) *
                         static_cast<std::uint64_t>(std::max(1, spec.tile_height)) *
                         static_cast<std::uint64_t>(std::max(1, spec.tile_depth)) * pixel;
    } else {
        p.band = 64;
        // A TIFF strip is inflated whole (libtiff), however few of its rows are asked for.
        const int rows = std::min(spec.height, spec.get_int_attribute("tiff:RowsPerStrip", 1));
        p.reader_chunk = width * static_cast<std::uint64_t>(std::max(1, rows)) * pixel;
    }
    const auto pixels = width * static_cast<std::uint64_t>(spec.height);
    p.held = pixels * p.src.size() * 4 +
             width * static_cast<std::uint64_t>(std::min(p.band, spec.height)) *
                 static_cast<std::uint64_t>(p.read_channels) * 4 +
             p.reader_chunk;
    return p;
}

// What the header says, checked before a pixel is decoded: a flat image within the budget, whose
// reader inflates at most limits.max_reader_chunk bytes at once; then how to decode it.
Result<DecodePlan> checked_plan(const ImageSpec& spec, const DecodeLimits& limits) {
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.depth != 1)
        return unprocessable("image has no pixels or is a volume (" + std::to_string(spec.width) +
                             "x" + std::to_string(spec.height) + ")");
    const std::uint64_t pixels = static_cast<std::uint64_t>(spec.width) * spec.height;
    if (pixels > limits.max_pixels)
        return make_error(ErrorCode::too_large,
                          "image is " + std::to_string(spec.width) + "x" +
                              std::to_string(spec.height) + " = " + std::to_string(pixels) +
                              " pixels, over the budget of " + std::to_string(limits.max_pixels));
    if (spec.nchannels > 16) return unprocessable("image has too many channels");
    const DecodePlan plan = plan_decode(spec, limits);
    if (plan.reader_chunk > limits.max_reader_chunk)
        return unprocessable(
            std::string("image is stored in ") +
            (spec.tile_width > 0 ? "tiles of " + std::to_string(spec.tile_width) + "x" +
                                       std::to_string(spec.tile_height)
                                 : "strips of " + std::to_string(spec.width) + " pixels") +
            " with " + std::to_string(spec.nchannels) + " channels: " +
            std::to_string(plan.reader_chunk >> 20) + " MiB a piece to decode, over the " +
            std::to_string(limits.max_reader_chunk >> 20) + " MiB a decoder may hold");
    return plan;
}

Result<core::Image> read_opened(ImageInput& in, const DecodeLimits& limits, int* bits = nullptr) {
    const ImageSpec& spec = in.spec();
    if (bits) *bits = static_cast<int>(spec.format.size()) * 8;
    auto checked = checked_plan(spec, limits);
    if (!checked) return checked.error();
    const DecodePlan& plan = checked.value();
    const int out_channels = static_cast<int>(plan.src.size());
    const int nread = plan.read_channels;
    core::Image img(spec.width, spec.height, out_channels);
    // In bands of rows (of tiles, for a tiled file), only the channels kept, each band turned
    // into the planes at once: a decode holds the planes and one band, not the interleaved
    // floats of the whole image beside them (a 4096^2 RGB upload held 400 MB where 200 MB is the
    // image; a tiled TIFF of 16 float channels, read whole, 3.3 GiB).
    const auto width = static_cast<std::size_t>(spec.width);
    std::vector<float> buf(width * static_cast<std::size_t>(std::min(plan.band, spec.height)) *
                           static_cast<std::size_t>(nread));
    for (int y0 = 0; y0 < spec.height; y0 += plan.band) {
        const int y1 = std::min(spec.height, y0 + plan.band);
        const bool read =
            spec.tile_width > 0
                ? in.read_tiles(0, 0, spec.x, spec.x + spec.width, spec.y + y0, spec.y + y1, spec.z,
                                spec.z + 1, 0, nread, TypeDesc::FLOAT, buf.data())
                : in.read_scanlines(0, 0, spec.y + y0, spec.y + y1, 0, 0, nread, TypeDesc::FLOAT,
                                    buf.data());
        if (!read || in.has_error())
            return unprocessable("cannot decode image: " + oiio_message(in.geterror()));
        const std::size_t first = static_cast<std::size_t>(y0) * width;
        const std::size_t count = static_cast<std::size_t>(y1 - y0) * width;
        for (std::size_t k = 0; k < count; ++k)
            for (int c = 0; c < out_channels; ++c) {
                const float v =
                    buf[k * static_cast<std::size_t>(nread) +
                        static_cast<std::size_t>(plan.src[static_cast<std::size_t>(c)])];
                if (!std::isfinite(v))
                    return unprocessable("image contains NaN or infinite values");
                img.plane(c)[first + k] = v;
            }
    }
    return img;
}

// Keep colour as stored: OpenImageIO would otherwise premultiply by the alpha we then drop.
const ImageSpec& read_config() {
    static const ImageSpec config = [] {
        ImageSpec c;
        c.attribute("oiio:UnassociatedAlpha", 1);
        return c;
    }();
    return config;
}

// An in-memory I/O proxy that never reads outside its bytes. OpenImageIO 2.4's IOMemReader
// copies past the end of its buffer when a reader asks for an offset beyond it (a heap overflow
// reached through the EXR reader, found by tests/fuzz).
class BoundedMemoryReader final : public OIIO::Filesystem::IOProxy {
public:
    explicit BoundedMemoryReader(std::string_view bytes) : IOProxy("", Read), m_bytes(bytes) {}
    const char* proxytype() const override { return "textond-memory"; }
    size_t size() const override { return m_bytes.size(); }
    size_t pread(void* buf, size_t n, int64_t offset) override {
        if (offset < 0 || static_cast<std::uint64_t>(offset) >= m_bytes.size()) return 0;
        const std::size_t at = static_cast<std::size_t>(offset);
        const std::size_t count = std::min(n, m_bytes.size() - at);
        std::memcpy(buf, m_bytes.data() + at, count);
        return count;
    }
    size_t read(void* buf, size_t n) override {
        const std::size_t count = pread(buf, n, m_pos);
        m_pos += static_cast<int64_t>(count);
        return count;
    }

private:
    std::string_view m_bytes;
};

} // namespace

bool png_complete(std::string_view bytes) {
    return png_chunks_complete(bytes);
}

// A file goes through the upload's path (decode_image_memory): the same sniffing, allow-list,
// header checks and JPEG metadata stripping, so a photo gives the same pixels (and texton)
// whether it was uploaded or named on the command line.
Result<core::Image> decode_image_file(const std::string& path, const DecodeLimits& limits,
                                      int* bits) {
    std::error_code ec;
    const fs::file_status status = fs::status(path, ec);
    if (ec && ec != std::errc::no_such_file_or_directory)
        return make_error(ErrorCode::io, "cannot read " + path + ": " + ec.message());
    if (!fs::exists(status)) return make_error(ErrorCode::not_found, "no such file: " + path);
    if (!fs::is_regular_file(status))
        return make_error(ErrorCode::invalid_argument,
                          "not a regular file (a directory, FIFO or device): " + path);
    const std::uintmax_t size = fs::file_size(path, ec);
    if (ec) return make_error(ErrorCode::io, "cannot read " + path + ": " + ec.message());
    if (size == 0) return unprocessable("file is empty: " + path);
    // No image within the pixel budget is larger: the 16 channels the reader takes, of 64-bit
    // samples, uncompressed, and room for headers and metadata.
    constexpr std::uint64_t kSlack = 16U << 20;
    constexpr std::uint64_t kPixelBytes = 16 * 8;
    const std::uint64_t cap = limits.max_pixels > (UINT64_MAX - kSlack) / kPixelBytes
                                  ? UINT64_MAX
                                  : limits.max_pixels * kPixelBytes + kSlack;
    if (size > cap)
        return make_error(ErrorCode::too_large, path + " has " + std::to_string(size) +
                                                    " bytes, more than any image of at most " +
                                                    std::to_string(limits.max_pixels) + " pixels");
    auto bytes = read_file(path);
    if (!bytes) return bytes.error();
    return decode_image_memory(bytes.value(), limits, bits);
}

std::string sniff_format(std::string_view b) {
    auto starts = [&](std::string_view magic) { return b.substr(0, magic.size()) == magic; };
    using namespace std::string_view_literals;
    if (starts("\x89PNG\r\n\x1a\n"sv)) return "png";
    if (starts("\xff\xd8\xff"sv)) return "jpeg";
    if (starts("II*\0"sv) || starts("MM\0*"sv)) return "tiff";
    if (starts("\x76\x2f\x31\x01"sv)) return "openexr";
    if (starts("BM"sv) && b.size() >= 26) return "bmp";
    return "";
}

namespace {
// Opens `bytes` with the sniffed format's reader alone, as an upload (the checks of
// decode_image_memory before a pixel is read); `keep` holds what the reader reads from.
struct OpenedUpload {
    std::string stripped;
    std::unique_ptr<BoundedMemoryReader> bounded;
    std::unique_ptr<OIIO::Filesystem::IOMemReader> whole;
    std::unique_ptr<ImageInput> in; // last: closed before its readers go
};
Result<OpenedUpload> open_upload(std::string_view bytes, const DecodeLimits& limits);
} // namespace

Result<ImageHeader> image_header_memory(std::string_view bytes, const DecodeLimits& limits) {
    auto opened = open_upload(bytes, limits);
    if (!opened) return opened.error();
    const ImageSpec& spec = opened.value().in->spec();
    auto plan = checked_plan(spec, limits);
    if (!plan) return plan.error();
    return ImageHeader{spec.width, spec.height, spec.nchannels,
                       static_cast<int>(spec.format.size()) * 8,
                       static_cast<std::size_t>(plan.value().held)};
}

Result<core::Image> decode_image_memory(std::string_view bytes, const DecodeLimits& limits,
                                        int* bits) {
    auto opened = open_upload(bytes, limits);
    if (!opened) return opened.error();
    return read_opened(*opened.value().in, limits, bits);
}

namespace {
Result<OpenedUpload> open_upload(std::string_view bytes, const DecodeLimits& limits) {
    if (bytes.empty()) return unprocessable("image is empty");
    const std::string format = sniff_format(bytes);
    const bool allowed = !format.empty() && (limits.formats.empty() ||
                                             std::find(limits.formats.begin(), limits.formats.end(),
                                                       format) != limits.formats.end());
    if (!allowed)
        return make_error(ErrorCode::unsupported,
                          format.empty()
                              ? "not an image in a format we read (PNG, JPEG, TIFF, BMP, "
                                "OpenEXR where enabled)"
                              : "image format '" + format + "' is not accepted here");
    if (format == "png" && !png_chunks_complete(bytes))
        return unprocessable("PNG is truncated (a chunk runs past the end, or no IEND)");
    if (format == "openexr")
        if (auto err = exr_header_check(bytes, limits.max_pixels)) return *err;
    OpenedUpload out;
    if (format == "png") {
        out.stripped = png_without_text(bytes);
        if (!out.stripped.empty()) bytes = out.stripped;
    }
    if (format == "jpeg") {
        out.stripped = jpeg_without_metadata(bytes);
        if (out.stripped.empty())
            return unprocessable("JPEG is truncated or its segments are broken");
        // libjpeg decodes every scan of a progressive JPEG over the whole image, and a scan can
        // be 10 bytes: 100,000 of them in 1 MB took 200 s of CPU for one 4096 x 4096 upload.
        // Encoders write 1 scan (baseline) or about 10 (libjpeg's progressive script).
        if (const std::size_t scans = jpeg_scans(out.stripped); scans > kMaxJpegScans)
            return unprocessable("JPEG has " + std::to_string(scans) + " scans; at most " +
                                 std::to_string(kMaxJpegScans) + " are decoded");
        bytes = out.stripped;
    }
    // Decoded straight from memory (every accepted format's reader takes an I/O proxy), so an
    // upload needs no disk: a full disk must not make a good image look bad. Only the sniffed
    // format's reader sees the bytes (OpenImageIO's open() would try every reader it has).
    auto in = ImageInput::create(format);
    if (!in || !in->supports("ioproxy"))
        return make_error(ErrorCode::unsupported, "no in-memory reader for " + format);
    // OpenImageIO's JPEG reader takes only its own memory reader, whose buffer it hands whole
    // to libjpeg (which checks bounds itself); every other reader gets the bounded one.
    out.bounded = std::make_unique<BoundedMemoryReader>(bytes);
    out.whole = std::make_unique<OIIO::Filesystem::IOMemReader>(bytes.data(), bytes.size());
    void* proxy = format == "jpeg" ? static_cast<void*>(out.whole.get())
                                   : static_cast<void*>(out.bounded.get());
    ImageSpec config = read_config();
    config.attribute("oiio:ioproxy", TypeDesc::PTR, static_cast<const void*>(&proxy));
    ImageSpec opened;
    if (!in->open("upload." + format, opened, config))
        return unprocessable("cannot decode " + format + " image: " + oiio_message(in->geterror()));
    out.in = std::move(in);
    return out;
}
} // namespace

Result<Encoding> encoding_for_path(const std::string& path) {
    std::string ext = fs::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    if (ext == ".png") return Encoding::png8;
    if (ext == ".exr") return Encoding::exr;
    return make_error(ErrorCode::invalid_argument,
                      "output must end in .png or .exr, not '" + ext + "'");
}

const char* extension_of(Encoding e) {
    switch (e) {
    case Encoding::png8:
    case Encoding::png16:
        return ".png";
    case Encoding::exr:
        return ".exr";
    }
    return "";
}

Result<std::string> read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return make_error(ErrorCode::not_found, "cannot open " + path);
    std::ostringstream out;
    out << in.rdbuf();
    if (in.bad()) return make_error(ErrorCode::io, "cannot read " + path);
    return out.str();
}

Result<bool> write_file_atomic(const std::string& path, std::string_view bytes) {
    auto file = AtomicFile::create(path);
    if (!file) return file.error();
    if (auto w = file.value()->write(bytes); !w) return w.error();
    const fs::path target(path);
    const std::string ext = target.extension().string().substr(target.has_extension() ? 1 : 0);
    return file.value()->commit(ext.c_str());
}

namespace {

// Buffers reused while small: serve maps every allocation over 128 kB on its own, so a fresh
// buffer per tile costs page faults each time. At most 16 of at most 2 MiB each are kept (32 MiB)
// for each kind: the encoder's scratch (interleaved pixels, the encoded stream) and the strings
// of encoded images (recycle_encoded).
template <class Buffer> class Spares {
public:
    Buffer take() {
        std::lock_guard lock(m_mutex);
        if (m_free.empty()) return {};
        Buffer b = std::move(m_free.back());
        m_free.pop_back();
        b.clear();
        return b;
    }
    void give(Buffer&& b) {
        if (b.capacity() < 4096 || b.capacity() > (std::size_t{2} << 20)) return;
        std::lock_guard lock(m_mutex);
        if (m_free.size() < 16) m_free.push_back(std::move(b));
    }

private:
    std::mutex m_mutex;
    std::vector<Buffer> m_free;
};

Spares<std::vector<unsigned char>> g_scratch;
Spares<std::string> g_encoded;

// One scratch buffer for a scope.
struct Scratch {
    Scratch() : bytes(g_scratch.take()) {}
    ~Scratch() { g_scratch.give(std::move(bytes)); }
    Scratch(const Scratch&) = delete;
    Scratch& operator=(const Scratch&) = delete;
    std::vector<unsigned char> bytes;
};

// The encoder writes straight into the string that is returned: OpenImageIO's IOVecOutput
// zero-fills what each write adds before copying it in, under a mutex, and its vector was then
// copied once more into a string (2.2% and part of 2.2% of a cold CPU tile's server time).
class StringOutput final : public OIIO::Filesystem::IOProxy {
public:
    explicit StringOutput(std::string& out) : IOProxy("", Write), m_out(out) {}
    const char* proxytype() const override { return "textond-string"; }
    std::size_t write(const void* buf, std::size_t size) override {
        const std::size_t n = pwrite(buf, size, m_pos);
        m_pos += static_cast<std::int64_t>(n);
        return n;
    }
    std::size_t pwrite(const void* buf, std::size_t size, std::int64_t offset) override {
        const auto at = static_cast<std::size_t>(offset);
        const char* bytes = static_cast<const char*>(buf);
        if (at == m_out.size()) { // the usual case: appended, one copy
            m_out.append(bytes, size);
        } else { // a writer that seeks back (or past the end) to fill in an offset table
            if (at + size > m_out.size()) m_out.resize(at + size);
            std::memcpy(m_out.data() + at, bytes, size);
        }
        return size;
    }
    std::size_t size() const override { return m_out.size(); }

private:
    std::string& m_out;
};

struct EncodeInput {
    ImageSpec spec;
    TypeDesc type;
    const unsigned char* pixels; // interleaved, in `type`
};

void interleave_floats(const core::Image& image, float* out) {
    const std::size_t n = image.plane_size();
    const int nc = image.channels;
    if (nc < 1 || nc > 8) throw std::invalid_argument("encode: 1 to 8 channels");
    // Pixel-major, so the writes are sequential (channel-major strided stores were 10% of a cold
    // tile's CPU time).
    const float* planes[8] = {};
    for (int c = 0; c < nc; ++c) planes[c] = image.plane(c);
    for (std::size_t k = 0; k < n; ++k)
        for (int c = 0; c < nc; ++c) out[k * nc + c] = planes[c][k];
}

template <class T> void interleave_quantised(const core::Image& image, T* out) {
    if (image.channels < 1 || image.channels > 4)
        throw std::invalid_argument("encode: 1 to 4 channels for 8 or 16 bits");
    const float* planes[4] = {};
    for (int c = 0; c < image.channels; ++c) planes[c] = image.plane(c);
    quantise_interleaved(planes, image.channels, image.plane_size(), out);
}

// The pixels are converted here, not by OpenImageIO: its conversion of a small image fans out
// to its thread pool, which costs more than the work on a server that is busy already.
EncodeInput prepare_encode(const core::Image& image, Encoding e, const Attributes& attributes,
                           std::vector<unsigned char>& pixels,
                           const std::vector<std::string>& channel_names = {}) {
    if (image.channels > (e == Encoding::exr ? 8 : 4))
        throw std::invalid_argument("encode: too many channels for the format");
    const TypeDesc type = e == Encoding::png8    ? TypeDesc::UINT8
                          : e == Encoding::png16 ? TypeDesc::UINT16
                                                 : TypeDesc::FLOAT;
    EncodeInput in{ImageSpec(image.width, image.height, image.channels, type), type, nullptr};
    if (e == Encoding::exr) {
        in.spec.attribute("compression", "zip");
        // OpenEXR's writer stamps the current time (capDate) unless a DateTime is given: the
        // same pixels must be the same bytes (strong ETags, replicas, restarts), so a fixed one.
        in.spec.attribute("DateTime", "1970:01:01 00:00:00");
    }
    if (image.channels == 1) in.spec.channelnames = {"Y"};
    if (static_cast<int>(channel_names.size()) == image.channels)
        in.spec.channelnames = channel_names;
    for (const auto& [key, value] : attributes) in.spec.attribute(key, value);
    if (image.is_bytes()) { // already what a PNG of 8 bits holds (a GL tile's readback)
        if (e != Encoding::png8) throw std::invalid_argument("encode: 8-bit pixels as 8-bit PNG");
        in.pixels = image.bytes.data();
        return in;
    }
    pixels.resize(image.data.size() * type.size());
    if (e == Encoding::png8)
        interleave_quantised(image, pixels.data());
    else if (e == Encoding::png16)
        interleave_quantised(image, reinterpret_cast<std::uint16_t*>(pixels.data()));
    else
        interleave_floats(image, reinterpret_cast<float*>(pixels.data()));
    in.pixels = pixels.data();
    return in;
}

} // namespace

Result<std::string> encode_image_memory(const core::Image& image, Encoding e,
                                        const Attributes& attributes, int png_compression,
                                        const std::vector<std::string>& channel_names) {
    if (image.empty()) return make_error(ErrorCode::invalid_argument, "nothing to encode");
    Scratch pixels;
    EncodeInput in = prepare_encode(image, e, attributes, pixels.bytes, channel_names);
    if (e != Encoding::exr) {
        in.spec.attribute("png:compressionLevel", png_compression);
        // Stored (level 0): filters are wasted work. Compressed: the Average filter alone gives
        // nearly the size of libpng's five-filter search on texton noise in half the time
        // (measured on 256x256 tiles: -39% bytes for cork, -19% for sand, at level 1).
        in.spec.attribute("png:filter", png_compression == 0 ? 8 /* PNG_FILTER_NONE */
                                                             : 64 /* PNG_FILTER_AVG */);
    }
    std::string bytes = g_encoded.take();
    const std::size_t raw =
        image.plane_size() * static_cast<std::size_t>(image.channels) * in.type.size();
    bytes.reserve(raw + raw / 64 + 4096); // stored PNG, no regrowth
    StringOutput proxy(bytes);
    void* proxy_ptr = &proxy;
    in.spec.attribute("oiio:ioproxy", TypeDesc::PTR, static_cast<const void*>(&proxy_ptr));
    // One encoder per thread and format, reused: creating one looks up the plugin each time.
    // The name only picks the encoder; with an I/O proxy nothing touches the filesystem.
    const char* name = e == Encoding::exr ? "tile.exr" : "tile.png";
    thread_local std::unique_ptr<ImageOutput> encoders[2];
    std::unique_ptr<ImageOutput>& out = encoders[e == Encoding::exr ? 1 : 0];
    if (!out) out = ImageOutput::create(name);
    if (!out) return make_error(ErrorCode::io, "no encoder: " + oiio_message(OIIO::geterror()));
    const bool ok =
        out->open(name, in.spec) && out->write_image(in.type, in.pixels) && out->close();
    if (!ok) {
        const std::string err = oiio_message(out->geterror());
        out.reset(); // never reuse an encoder in an unknown state
        g_encoded.give(std::move(bytes));
        return make_error(ErrorCode::internal, "cannot encode: " + err);
    }
    return bytes;
}

void recycle_encoded(std::string&& bytes) {
    g_encoded.give(std::move(bytes));
}

Result<bool> encode_image_file(const core::Image& image, const std::string& path, Encoding e,
                               const Attributes& attributes) {
    if (image.empty()) return make_error(ErrorCode::invalid_argument, "nothing to encode");
    Scratch pixels;
    const EncodeInput in = prepare_encode(image, e, attributes, pixels.bytes);
    const ImageSpec& spec = in.spec;
    // Encode next to the target under a temporary name, then rename: never a half-written file.
    const fs::path target(path);
    const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
    std::mt19937_64 salt(std::random_device{}());
    const std::string tmp = (dir / ("." + target.filename().string() + ".tmp" +
                                    std::to_string(salt() % 1000000) + extension_of(e)))
                                .string();
    auto out = ImageOutput::create(tmp);
    if (!out) return make_error(ErrorCode::io, "no encoder: " + oiio_message(OIIO::geterror()));
    bool ok = out->open(tmp, spec) && out->write_image(in.type, in.pixels) && out->close();
    if (ok) {
        const int fd = ::open(tmp.c_str(), O_RDONLY);
        ok = fd >= 0 && ::fsync(fd) == 0;
        if (fd >= 0) ::close(fd);
    }
    if (!ok || std::rename(tmp.c_str(), path.c_str()) != 0) {
        std::string err = out->geterror();
        ::unlink(tmp.c_str());
        return make_error(ErrorCode::io,
                          "cannot write " + path + ": " +
                              (err.empty() ? std::strerror(errno) : oiio_message(err)));
    }
    return true;
}

std::string pixels_sha256(const core::Image& image) {
    Sha256 h;
    h.update(std::to_string(image.width) + "x" + std::to_string(image.height) + "\n");
    h.update(std::string_view(reinterpret_cast<const char*>(image.data.data()),
                              image.data.size() * sizeof(float)));
    return h.hex();
}

} // namespace textond::io
