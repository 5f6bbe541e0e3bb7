#pragma once
// Client text echoed back in an error message or written to a log line: bytes a hostile client
// chose. JSON encoders throw on invalid UTF-8 (nlohmann's type_error.316, once a 500 for
// `?seed=%ff`) and a raw newline in a log line forges another line, so every echo goes through
// here first.
#include <cstddef>
#include <string>
#include <string_view>

namespace textond::api {

// Valid UTF-8 with no control characters, at most `max_bytes` long: well-formed UTF-8
// sequences stay as they are, every other byte (invalid or truncated sequences, overlongs,
// surrogates, C0 controls, DEL, C1 controls) becomes `\xNN`, and a longer result is cut at a
// character boundary and ends with "...". Never throws but for allocation.
std::string printable(std::string_view s, std::size_t max_bytes = 200);

// Length of the well-formed UTF-8 sequence at the start of `s` (1-4), or 0 when it is not one
// (RFC 3629: no overlongs, no surrogates, nothing above U+10FFFF).
std::size_t utf8_sequence_length(std::string_view s);

} // namespace textond::api
