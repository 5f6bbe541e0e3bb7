#include "render/gl/gl_api.h"

namespace textond::render::gl {

std::string GlApi::load(Loader get, void* user) {
// `type` is a type, which parentheses would break.
// NOLINTBEGIN(bugprone-macro-parentheses)
#define TEXTOND_GL_LOAD(type, name)                                                                \
    name = reinterpret_cast<type>(get("gl" #name, user));                                          \
    if (!name) return "gl" #name;
    // NOLINTEND(bugprone-macro-parentheses)
    TEXTOND_GL_FUNCTIONS(TEXTOND_GL_LOAD)
#undef TEXTOND_GL_LOAD
    return "";
}

} // namespace textond::render::gl
