#pragma once
// The names http imports: the transport serves the application (server/app/) and its stores
// (server/store/), their names unqualified in textond::http. Nothing below http includes this
// (tests/style/layers_test.py).
namespace textond::app {}
namespace textond::store {}

namespace textond::http {
using namespace textond::app;   // NOLINT(google-build-using-namespace): the layer's one import
using namespace textond::store; // NOLINT(google-build-using-namespace)
} // namespace textond::http
