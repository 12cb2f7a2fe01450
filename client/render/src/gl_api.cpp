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
    // optional: a loader may hand back a stub for a name the context does not support, so these
    // are used only where version() or hasExtension() says so
#define TERRAIN_GL_LOAD_OPTIONAL(type, name)                                                       \
    {                                                                                              \
        void* p = loader("gl" #name, user);                                                        \
        static_assert(sizeof(name) == sizeof(p));                                                  \
        std::memcpy(&name, &p, sizeof(p));                                                         \
    }
    TERRAIN_GL_OPTIONAL_FUNCTIONS(TERRAIN_GL_LOAD_OPTIONAL)
#undef TERRAIN_GL_LOAD_OPTIONAL
    return Ok{};
}

int GlApi::version() const {
    GLint major = 0;
    GLint minor = 0;
    GetIntegerv(GL_MAJOR_VERSION, &major);
    GetIntegerv(GL_MINOR_VERSION, &minor);
    return major * 10 + minor;
}

bool GlApi::hasExtension(const char* name) const {
    GLint count = 0;
    GetIntegerv(GL_NUM_EXTENSIONS, &count);
    for (GLint i = 0; i < count; ++i) {
        const GLubyte* e = GetStringi(GL_EXTENSIONS, static_cast<GLuint>(i));
        if (e != nullptr && std::strcmp(reinterpret_cast<const char*>(e), name) == 0)
            return true;
    }
    return false;
}

} // namespace terrain::render
