#pragma once
// Image decoding and encoding through OpenImageIO (the only place that touches image formats).
//
// Decoding contract: any format OpenImageIO reads; first subimage; alpha dropped; grey (and
// grey+alpha) stays ONE channel, everything else becomes RGB (palette PNGs arrive as RGB);
// integer formats normalised to [0, 1], float formats kept as they are. The declared size is
// checked against the pixel budget before a single pixel is decoded; NaN/Inf are refused.
#include "core/image.h"
#include "core/result.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace textond::io {

// The most a reader inflates at once (a tile, or a TIFF strip, of every channel at the file's
// depth): one 4096 x 4096 tile of 16 float channels is 1 GiB, from a 1 MB upload. 128 MiB holds a
// single-strip 4096 x 4096 RGB image of 16 bits (96 MiB); more is refused before decoding (422).
inline constexpr std::uint64_t kMaxReaderChunk = std::uint64_t{128} << 20;

struct DecodeLimits {
    std::uint64_t max_pixels = 16'777'216; // 16.8 MP (4096 x 4096)
    // OpenImageIO format names the decoders accept ("png", "jpeg", "tiff", "openexr", "bmp");
    // empty = whatever sniff_format recognises (the command line's choice).
    std::vector<std::string> formats;
    // Every channel in the file's order, alpha included (a splat's weights: RGBA = 4 layers);
    // otherwise the colour channels only, 1 or 3.
    bool all_channels = false;
    // The most a reader may inflate at once (kMaxReaderChunk; tests set less).
    std::uint64_t max_reader_chunk = kMaxReaderChunk;
};

// The most scans of a JPEG decoded (a progressive one has about 10): each is a pass over the
// whole image, so more are refused before decoding (422), at 100 about 0.3 s for 4096 x 4096.
inline constexpr std::size_t kMaxJpegScans = 100;

// Whether every chunk of a PNG lies inside `bytes`, up to IEND (a truncated file does not).
bool png_complete(std::string_view bytes);

// The format named by the first bytes (magic numbers), as an OpenImageIO format name, or ""
// when none of the formats we accept for uploads starts that way.
std::string sniff_format(std::string_view bytes);

// Uploads, decoded in memory: the format is sniffed from the bytes and must be in
// `limits.formats` (else ErrorCode::unsupported), and only that format's reader sees the bytes.
// `bits`, when given, receives the file's bits per channel (8, 16, 32).
Result<core::Image> decode_image_memory(std::string_view bytes, const DecodeLimits& limits = {},
                                        int* bits = nullptr);
// What an upload's header says, with decode_image_memory's checks up to the first pixel: no pixel
// is decoded (admission sizes the decode from it).
struct ImageHeader {
    int width = 0, height = 0, channels = 0, bits = 8;
    // What decoding it holds at once: the kept channels' float planes, a band of rows and the
    // reader's own piece (a tile or a TIFF strip of every channel).
    std::size_t decode_bytes = 0;
};
Result<ImageHeader> image_header_memory(std::string_view bytes, const DecodeLimits& limits = {});

// A file: read whole (refused when larger than any image within the pixel budget could be) and
// decoded by decode_image_memory, with the same refusals as an upload. not_found when there is
// no such file, invalid_argument for a directory, FIFO or device.
Result<core::Image> decode_image_file(const std::string& path, const DecodeLimits& limits = {},
                                      int* bits = nullptr);

enum class Encoding { png8, png16, exr };

// The sha256 of an image's size and float pixels: what names a mask or weight image in its
// owner's metadata and content address.
std::string pixels_sha256(const core::Image& image);

// Chooses the encoding from the extension: .png (8-bit), .exr (float); anything else is an error.
Result<Encoding> encoding_for_path(const std::string& path);
const char* extension_of(Encoding e);

using Attributes = std::vector<std::pair<std::string, std::string>>;

// Encodes into memory (tiles): same conventions as encode_image_file. `png_compression` is zlib's
// level 0..9; noise barely compresses, so a low level saves time for a few percent of size.
// PNG takes 1 to 4 channels, EXR up to 8 (a material set's texton), named `channel_names` when
// given.
Result<std::string> encode_image_memory(const core::Image& image, Encoding e,
                                        const Attributes& attributes = {}, int png_compression = 6,
                                        const std::vector<std::string>& channel_names = {});

// The bytes of encoded images are reused: encode_image_memory writes into a string taken from a
// pool, and whoever drops an encoded image (the image cache, on eviction) may give its string
// back. serve maps every allocation over 128 kB on its own, so a fresh 200 kB string per cold
// tile was 50 page faults. At most 32 MiB of strings of at most 2 MiB each are kept.
void recycle_encoded(std::string&& bytes);

// Writes atomically (temporary file in the same directory, fsync, rename). PNG values are
// clamped to [0, 1]; EXR keeps floats (bit-exact). One-channel images are written as one channel
// ("Y"). `attributes` become string metadata of the file.
Result<bool> encode_image_file(const core::Image& image, const std::string& path, Encoding e,
                               const Attributes& attributes = {});

// The whole file, or not_found / io.
Result<std::string> read_file(const std::string& path);

// Atomic write of raw bytes (temp, fsync, rename): no reader ever sees half a file.
Result<bool> write_file_atomic(const std::string& path, std::string_view bytes);

} // namespace textond::io
