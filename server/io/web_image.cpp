#include "server/io/web_image.h"

#include "server/io/quantise.h"

#include <avif/avif.h>
#include <webp/encode.h>

#include <cmath>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

namespace textond::io {

namespace {

// libwebp's effort: lossless preset 0..9, lossy method 0..6. The fastest: against the defaults
// (3, 4) they cost a ninth and a fifth of the time for 11% and 0% more bytes (format_bench).
constexpr int kWebpLosslessLevel = 0;
constexpr int kWebpLossyMethod = 0;

// Interleaved 8-bit RGB, rounded as the PNG encoder rounds (quantise.h).
std::vector<std::uint8_t> rgb8(const core::Image& u) {
    if (u.is_bytes() && u.channels == 3) return u.bytes; // rounded already (a GL tile)
    std::vector<std::uint8_t> out(static_cast<std::size_t>(u.width) * u.height * 3);
    if (u.is_bytes()) { // grey repeats its byte
        for (std::size_t k = 0; k < u.bytes.size(); ++k)
            out[3 * k] = out[3 * k + 1] = out[3 * k + 2] = u.bytes[k];
        return out;
    }
    const float* planes[3] = {u.plane(0), u.plane(u.channels == 1 ? 0 : 1),
                              u.plane(u.channels == 1 ? 0 : 2)};
    quantise_interleaved(planes, 3, u.plane_size(), out.data());
    return out;
}

std::optional<Error> check_input(const core::Image& u) {
    if (u.empty()) return make_error(ErrorCode::invalid_argument, "nothing to encode");
    if (u.channels != 1 && u.channels != 3)
        return make_error(ErrorCode::invalid_argument,
                          "WebP and AVIF tiles hold grey or RGB images, not " +
                              std::to_string(u.channels) + " channels");
    return std::nullopt;
}

} // namespace

Result<Rgb8> to_rgb8(const core::Image& image) {
    if (auto e = check_input(image)) return *e;
    return Rgb8{image.width, image.height, rgb8(image)};
}

Result<Rgb8> take_rgb8(core::Image& image) {
    if (auto e = check_input(image)) return *e;
    if (image.is_bytes() && image.channels == 3) // the GL tile's bytes themselves, no copy
        return Rgb8{image.width, image.height, std::exchange(image.bytes, {})};
    return Rgb8{image.width, image.height, rgb8(image)};
}

Result<std::string> encode_webp(const core::Image& image, int quality) {
    auto rgb = to_rgb8(image);
    if (!rgb) return rgb.error();
    return encode_webp(std::move(rgb.value()), quality);
}

Result<std::string> encode_avif(const core::Image& image, int quality) {
    auto rgb = to_rgb8(image);
    if (!rgb) return rgb.error();
    return encode_avif(std::move(rgb.value()), quality);
}

Result<std::string> encode_webp(Rgb8 rgb, int quality, const std::function<bool()>& stop) {
    if (quality < 0 || quality > 100)
        return make_error(ErrorCode::invalid_argument, "WebP quality must be in [1, 100]");
    WebPConfig config;
    if (!WebPConfigInit(&config))
        return make_error(ErrorCode::internal, "libwebp: version mismatch");
    // Speed over the last percent of size: a tile is encoded on a request's thread, once per
    // cache miss (tests/bench/format_bench measures both; api/README.md "Formats for the web").
    const bool ok = quality == 0 ? WebPConfigLosslessPreset(&config, kWebpLosslessLevel) != 0
                                 : WebPConfigPreset(&config, WEBP_PRESET_DEFAULT,
                                                    static_cast<float>(quality)) != 0;
    config.thread_level = 0; // requests are the parallelism
    if (!ok) return make_error(ErrorCode::internal, "libwebp: bad configuration");
    if (quality != 0) config.method = kWebpLossyMethod;
    config.exact = 1; // lossless means every value, not every visible one
    WebPPicture pic;
    if (!WebPPictureInit(&pic)) return make_error(ErrorCode::internal, "libwebp: version mismatch");
    pic.use_argb = quality == 0 ? 1 : 0;
    pic.width = rgb.width;
    pic.height = rgb.height;
    WebPMemoryWriter writer;
    WebPMemoryWriterInit(&writer);
    pic.writer = WebPMemoryWrite;
    pic.custom_ptr = &writer;
    if (stop) {
        pic.user_data = const_cast<std::function<bool()>*>(&stop);
        pic.progress_hook = [](int, const WebPPicture* p) {
            return (*static_cast<const std::function<bool()>*>(p->user_data))() ? 0 : 1;
        };
    }
    std::unique_ptr<WebPPicture, void (*)(WebPPicture*)> owned_pic(&pic, WebPPictureFree);
    std::unique_ptr<WebPMemoryWriter, void (*)(WebPMemoryWriter*)> owned_out(&writer,
                                                                             WebPMemoryWriterClear);
    const bool imported = WebPPictureImportRGB(&pic, rgb.pixels.data(), rgb.width * 3) != 0;
    std::vector<std::uint8_t>().swap(rgb.pixels); // the picture holds its own copy
    if (imported && !WebPEncode(&config, &pic) && pic.error_code == VP8_ENC_ERROR_USER_ABORT)
        return make_error(ErrorCode::cancelled, "the WebP encode was abandoned");
    if (!imported || pic.error_code != VP8_ENC_OK)
        return make_error(ErrorCode::internal,
                          "libwebp could not encode the image (error " +
                              std::to_string(static_cast<int>(pic.error_code)) + ")");
    return std::string(reinterpret_cast<const char*>(writer.mem), writer.size);
}

Result<std::string> encode_avif(Rgb8 rgb, int quality) {
    if (quality < 1 || quality > 100)
        return make_error(ErrorCode::invalid_argument, "AVIF quality must be in [1, 100]");
    // 4:4:4: texture tiles have colour detail at the pixel scale that 4:2:0 would blur.
    std::unique_ptr<avifImage, void (*)(avifImage*)> img(
        avifImageCreate(static_cast<std::uint32_t>(rgb.width),
                        static_cast<std::uint32_t>(rgb.height), 8, AVIF_PIXEL_FORMAT_YUV444),
        avifImageDestroy);
    if (!img) return make_error(ErrorCode::internal, "libavif: out of memory");
    avifRGBImage view;
    avifRGBImageSetDefaults(&view, img.get());
    view.format = AVIF_RGB_FORMAT_RGB;
    view.depth = 8;
    view.pixels = rgb.pixels.data();
    view.rowBytes = static_cast<std::uint32_t>(rgb.width) * 3;
    const bool converted = avifImageRGBToYUV(img.get(), &view) == AVIF_RESULT_OK;
    std::vector<std::uint8_t>().swap(rgb.pixels); // before libaom's frame buffers come
    if (!converted)
        return make_error(ErrorCode::internal, "libavif could not convert the image to YUV");
    std::unique_ptr<avifEncoder, void (*)(avifEncoder*)> enc(avifEncoderCreate(),
                                                             avifEncoderDestroy);
    if (!enc) return make_error(ErrorCode::internal, "libavif: no encoder");
    // libavif 0.11 takes quantisers (0 best .. 63), not a quality: quality 100 is quantiser 0.
    const int q = static_cast<int>(std::lround((100.0 - quality) * 63.0 / 100.0));
    enc->minQuantizer = q;
    enc->maxQuantizer = q;
    enc->speed = AVIF_SPEED_FASTEST; // a tile is encoded on a request's thread, once per cache miss
    enc->maxThreads = 1;             // requests are the parallelism
    avifRWData out = AVIF_DATA_EMPTY;
    const avifResult r = avifEncoderWrite(enc.get(), img.get(), &out);
    std::unique_ptr<avifRWData, void (*)(avifRWData*)> owned(&out, avifRWDataFree);
    if (r != AVIF_RESULT_OK)
        return make_error(ErrorCode::internal,
                          std::string("libavif could not encode: ") + avifResultToString(r));
    return std::string(reinterpret_cast<const char*>(out.data), out.size);
}

} // namespace textond::io
