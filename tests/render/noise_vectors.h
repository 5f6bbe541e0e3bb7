#pragma once
// render/noise_vectors.json, loaded once for the spec tests of every backend.
#include "render/backend.h"
#include "render/prepared_texton.h"

#include <nlohmann/json.hpp>

#include <memory>

namespace textond::test {

const nlohmann::json& noise_vectors();
// The small textons the vectors were computed with.
std::shared_ptr<const render::PreparedTexton> vector_texton(int index);
// Every field value of the vectors, rendered as a 1x1 window by `backend` (tolerance: float
// accumulation against the reference's doubles).
void check_field_vectors(render::Backend& backend);

} // namespace textond::test
