#include "render/gl_functions.h"

#include "core/error.h"

namespace facesynth::render::detail {

void GlFunctions::load(const std::function<void*(const char*)>& get_proc_address, const std::string& backend) {
#define FACESYNTH_GL_LOAD(type, name)                                                            \
    name = reinterpret_cast<type>(get_proc_address("gl" #name));                                 \
    if (name == nullptr) throw core::Error(backend + ": OpenGL entry point gl" #name " is not available");  // NOLINT(bugprone-macro-parentheses): name is a member identifier, not an expression
    FACESYNTH_GL_FUNCTIONS(FACESYNTH_GL_LOAD)
#undef FACESYNTH_GL_LOAD
}

}  // namespace facesynth::render::detail
