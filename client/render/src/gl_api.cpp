#include <terrain/render/gl_api.h>

#include <cstring>
#include <string>

namespace terrain::render {

Status GlApi::load(Loader loader, void* user) {
    // each pointer comes back as void*; memcpy converts it without a cast between object and
    // function pointer types
#define TERRAIN_GL_LOAD(type, name)                                                                \
    {                                                                                              \
        void* p = loader("gl" #name, user);                                                        \
        if (p == nullptr)                                                                          \
            return makeError(                                                                      \
                ErrorCode::kUnsupported, "the OpenGL context does not provide gl" #name);          \
        static_assert(sizeof(name) == sizeof(p));                                                  \
        std::memcpy(&name, &p, sizeof(p));                                                         \
    }
    TERRAIN_GL_FUNCTIONS(TERRAIN_GL_LOAD)
#undef TERRAIN_GL_LOAD
    return Ok{};
}

} // namespace terrain::render
