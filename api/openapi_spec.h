#pragma once
// api/openapi.yaml, embedded at build time (api/CMakeLists.txt) and served at /v1/openapi.yaml.
namespace textond::api {
extern const char* const kOpenApiYaml;
}
