#pragma once
// render/noise_vectors.json, loaded once for the spec tests of every backend.
#include "render/prepared_texton.h"

#include <nlohmann/json.hpp>

#include <memory>

namespace textond::test {

const nlohmann::json& noise_vectors();
// The small textons the vectors were computed with.
std::shared_ptr<const render::PreparedTexton> vector_texton(int index);

} // namespace textond::test
