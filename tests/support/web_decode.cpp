#include "tests/support/web_decode.h"

#include <avif/avif.h>
#include <webp/decode.h>

#include <memory>

namespace textond::test {

namespace {

core::Image from_rgb8(const std::uint8_t* rgb, int w, int h, std::size_t row_bytes) {
    core::Image out(w, h, 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c)
                out.at(c, x, y) =
                    static_cast<float>(rgb[y * row_bytes + 3 * x + c]) * (1.0f / 255.0f);
    return out;
}

} // namespace

Result<core::Image> decode_webp(const std::string& bytes) {
    int w = 0, h = 0;
    std::uint8_t* rgb =
        WebPDecodeRGB(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size(), &w, &h);
    if (!rgb) return make_error(ErrorCode::invalid_argument, "not a WebP image");
    std::unique_ptr<std::uint8_t, void (*)(void*)> owned(rgb, WebPFree);
    return from_rgb8(rgb, w, h, static_cast<std::size_t>(w) * 3);
}

Result<core::Image> decode_avif(const std::string& bytes) {
    std::unique_ptr<avifImage, void (*)(avifImage*)> img(avifImageCreateEmpty(), avifImageDestroy);
    std::unique_ptr<avifDecoder, void (*)(avifDecoder*)> dec(avifDecoderCreate(),
                                                             avifDecoderDestroy);
    if (!img || !dec) return make_error(ErrorCode::internal, "libavif: out of memory");
    if (avifDecoderReadMemory(dec.get(), img.get(),
                              reinterpret_cast<const std::uint8_t*>(bytes.data()),
                              bytes.size()) != AVIF_RESULT_OK)
        return make_error(ErrorCode::invalid_argument, "not an AVIF image");
    avifRGBImage rgb;
    avifRGBImageSetDefaults(&rgb, img.get());
    rgb.format = AVIF_RGB_FORMAT_RGB;
    rgb.depth = 8;
    avifRGBImageAllocatePixels(&rgb);
    std::unique_ptr<avifRGBImage, void (*)(avifRGBImage*)> owned(&rgb, avifRGBImageFreePixels);
    if (avifImageYUVToRGB(img.get(), &rgb) != AVIF_RESULT_OK)
        return make_error(ErrorCode::internal, "libavif could not convert to RGB");
    return from_rgb8(rgb.pixels, static_cast<int>(img->width), static_cast<int>(img->height),
                     rgb.rowBytes);
}

} // namespace textond::test
