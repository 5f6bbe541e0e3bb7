#pragma once
// Decoders for the server's WebP and AVIF tiles (tests only: the server never reads them, and its
// upload allow-list leaves them out): libwebp and libavif, to 3-channel floats v / 255, the
// values the 8-bit PNG of the same tile decodes to.
#include "core/image.h"
#include "core/result.h"

#include <string>

namespace textond::test {

Result<core::Image> decode_webp(const std::string& bytes);
Result<core::Image> decode_avif(const std::string& bytes);

} // namespace textond::test
