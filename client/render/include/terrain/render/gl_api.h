#pragma once

// The OpenGL 3.3 core functions the renderer uses, as a table of function pointers filled from
// the current context's loader (OSMesaGetProcAddress, glfwGetProcAddress, later
// eglGetProcAddress). Nothing in the product calls gl* symbols directly: libOSMesa and libGL
// export the same names, so one process can hold a window and an offscreen context only if
// every call goes through the loader of the context it belongs to.

#include <terrain/result.h>

#include <GL/glcorearb.h>

#include <cstring>

namespace terrain::render {

// X(type, name): the table member `name` calls gl<name>.
#define TERRAIN_GL_FUNCTIONS(X)                                                                    \
    X(PFNGLGETSTRINGPROC, GetString)                                                               \
    X(PFNGLGETERRORPROC, GetError)                                                                 \
    X(PFNGLGETINTEGERVPROC, GetIntegerv)                                                           \
    X(PFNGLENABLEPROC, Enable)                                                                     \
    X(PFNGLDISABLEPROC, Disable)                                                                   \
    X(PFNGLVIEWPORTPROC, Viewport)                                                                 \
    X(PFNGLCLEARCOLORPROC, ClearColor)                                                             \
    X(PFNGLCLEARPROC, Clear)                                                                       \
    X(PFNGLDEPTHFUNCPROC, DepthFunc)                                                               \
    X(PFNGLPOLYGONMODEPROC, PolygonMode)                                                           \
    X(PFNGLPOLYGONOFFSETPROC, PolygonOffset)                                                       \
    X(PFNGLFINISHPROC, Finish)                                                                     \
    X(PFNGLPIXELSTOREIPROC, PixelStorei)                                                           \
    X(PFNGLREADBUFFERPROC, ReadBuffer)                                                             \
    X(PFNGLREADPIXELSPROC, ReadPixels)                                                             \
    X(PFNGLGENBUFFERSPROC, GenBuffers)                                                             \
    X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                                                       \
    X(PFNGLBINDBUFFERPROC, BindBuffer)                                                             \
    X(PFNGLBUFFERDATAPROC, BufferData)                                                             \
    X(PFNGLBUFFERSUBDATAPROC, BufferSubData)                                                       \
    X(PFNGLCOPYBUFFERSUBDATAPROC, CopyBufferSubData)                                               \
    X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                                                   \
    X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)                                             \
    X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                                                   \
    X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray)                                   \
    X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer)                                           \
    X(PFNGLDRAWELEMENTSPROC, DrawElements)                                                         \
    X(PFNGLDRAWARRAYSPROC, DrawArrays)                                                             \
    X(PFNGLCREATESHADERPROC, CreateShader)                                                         \
    X(PFNGLDELETESHADERPROC, DeleteShader)                                                         \
    X(PFNGLSHADERSOURCEPROC, ShaderSource)                                                         \
    X(PFNGLCOMPILESHADERPROC, CompileShader)                                                       \
    X(PFNGLGETSHADERIVPROC, GetShaderiv)                                                           \
    X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                                                 \
    X(PFNGLCREATEPROGRAMPROC, CreateProgram)                                                       \
    X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                                                       \
    X(PFNGLATTACHSHADERPROC, AttachShader)                                                         \
    X(PFNGLBINDATTRIBLOCATIONPROC, BindAttribLocation)                                             \
    X(PFNGLLINKPROGRAMPROC, LinkProgram)                                                           \
    X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                                                         \
    X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)                                               \
    X(PFNGLUSEPROGRAMPROC, UseProgram)                                                             \
    X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)                                             \
    X(PFNGLUNIFORM1FPROC, Uniform1f)                                                               \
    X(PFNGLUNIFORM2FPROC, Uniform2f)                                                               \
    X(PFNGLUNIFORM3FPROC, Uniform3f)                                                               \
    X(PFNGLUNIFORM4FPROC, Uniform4f)                                                               \
    X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv)                                                 \
    X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                                                   \
    X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)                                             \
    X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                                                   \
    X(PFNGLGENRENDERBUFFERSPROC, GenRenderbuffers)                                                 \
    X(PFNGLDELETERENDERBUFFERSPROC, DeleteRenderbuffers)                                           \
    X(PFNGLBINDRENDERBUFFERPROC, BindRenderbuffer)                                                 \
    X(PFNGLRENDERBUFFERSTORAGEPROC, RenderbufferStorage)                                           \
    X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, FramebufferRenderbuffer)                                   \
    X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)                                     \
    X(PFNGLGETSTRINGIPROC, GetStringi)                                                             \
    X(PFNGLFLUSHPROC, Flush)                                                                       \
    X(PFNGLGETBUFFERSUBDATAPROC, GetBufferSubData)                                                 \
    X(PFNGLGETBUFFERPARAMETERIVPROC, GetBufferParameteriv)                                         \
    X(PFNGLISBUFFERPROC, IsBuffer)                                                                 \
    X(PFNGLMAPBUFFERRANGEPROC, MapBufferRange)                                                     \
    X(PFNGLUNMAPBUFFERPROC, UnmapBuffer)                                                           \
    X(PFNGLFENCESYNCPROC, FenceSync)                                                               \
    X(PFNGLCLIENTWAITSYNCPROC, ClientWaitSync)                                                     \
    X(PFNGLDELETESYNCPROC, DeleteSync)                                                             \
    X(PFNGLGENQUERIESPROC, GenQueries)                                                             \
    X(PFNGLDELETEQUERIESPROC, DeleteQueries)                                                       \
    X(PFNGLBEGINQUERYPROC, BeginQuery)                                                             \
    X(PFNGLENDQUERYPROC, EndQuery)                                                                 \
    X(PFNGLGETQUERYOBJECTIVPROC, GetQueryObjectiv)                                                 \
    X(PFNGLGETQUERYOBJECTUI64VPROC, GetQueryObjectui64v)

// Functions beyond 3.3 core, null where the context lacks them: KHR_debug (core in 4.3) and
// ARB_buffer_storage (core in 4.4). hasExtension() says whether to use them.
#define TERRAIN_GL_OPTIONAL_FUNCTIONS(X)                                                           \
    X(PFNGLDEBUGMESSAGECALLBACKPROC, DebugMessageCallback)                                         \
    X(PFNGLDEBUGMESSAGECONTROLPROC, DebugMessageControl)                                           \
    X(PFNGLBUFFERSTORAGEPROC, BufferStorage)

struct GlApi {
#define TERRAIN_GL_MEMBER(type, name) type name = nullptr;
    TERRAIN_GL_FUNCTIONS(TERRAIN_GL_MEMBER)
    TERRAIN_GL_OPTIONAL_FUNCTIONS(TERRAIN_GL_MEMBER)
#undef TERRAIN_GL_MEMBER

    using Loader = void* (*)(const char* name, void* user);

    /// Fills every entry through `loader` (with the context current). Errors: kUnsupported
    /// naming the first function the context does not provide.
    Status load(Loader loader, void* user);

    /// The context's major * 10 + minor version (33 for 3.3).
    int version() const;
    /// Whether the context lists the extension (GL_NUM_EXTENSIONS / glGetStringi).
    bool hasExtension(const char* name) const;
};

/// A loader's function pointer as the void* that GlApi::load takes (memcpy: no cast between
/// function and object pointer types).
template <typename Function> void* loaderPointer(Function f) {
    void* p = nullptr;
    static_assert(sizeof(f) == sizeof(p));
    std::memcpy(&p, &f, sizeof(p));
    return p;
}

} // namespace terrain::render
