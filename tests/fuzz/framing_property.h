#pragma once
// The framing property: see framing_property.cpp.
#include <cstddef>
#include <cstdint>

namespace textond::test {

// Builds a stream of up to seven requests from `data` (methods, framings good and broken, bodies
// holding requests), serves it through the service's connection loop, and traps when it gets
// more answers than requests, fewer than well-framed requests, answers out of order, or an answer
// to a request hidden in a body.
void check_framing_property(const std::uint8_t* data, std::size_t size);

} // namespace textond::test
