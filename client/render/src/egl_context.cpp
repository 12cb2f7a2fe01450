#include <terrain/render/egl_context.h>

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstring>
#include <string>

namespace terrain::render {

namespace {
std::string eglFailure(const char* step) {
    char code[16];
    std::snprintf(code, sizeof code, "0x%04x", static_cast<unsigned>(eglGetError()));
    return std::string("EGL: ") + step + " failed (error " + code + ")";
}
} // namespace

Result<std::unique_ptr<EglContext>>
EglContext::create(int width, int height, const ContextOptions& options) {
    if (width < 1 || height < 1 || width > 8192 || height > 8192)
        return makeError(
            ErrorCode::kOutOfRange, "offscreen size " + std::to_string(width) + " x " +
                                        std::to_string(height) +
                                        " must be within 1..8192 per side");
    const char* extensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (extensions == nullptr ||
        std::strstr(extensions, "EGL_MESA_platform_surfaceless") == nullptr)
        return makeError(
            ErrorCode::kUnsupported,
            "EGL: no EGL_MESA_platform_surfaceless (Debian: libegl-mesa0)");
    // eglGetPlatformDisplay is EGL 1.5; the surfaceless platform needs no native display
    const auto get_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (get_display == nullptr)
        return makeError(ErrorCode::kUnsupported, "EGL: no eglGetPlatformDisplayEXT");
    EGLDisplay display = get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    EGLint major = 0;
    EGLint minor = 0;
    if (display == EGL_NO_DISPLAY || eglInitialize(display, &major, &minor) != EGL_TRUE)
        return makeError(ErrorCode::kUnsupported, eglFailure("eglInitialize (surfaceless)"));
    std::unique_ptr<EglContext> c(new EglContext());
    c->display_ = display;
    c->width_ = width;
    c->height_ = height;
    if (eglBindAPI(EGL_OPENGL_API) != EGL_TRUE)
        return makeError(ErrorCode::kUnsupported, eglFailure("eglBindAPI(OpenGL)"));
    // the default EGL_SURFACE_TYPE (window) matches nothing on the surfaceless platform
    const EGLint config_attributes[] = {
        EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint configs = 0;
    if (eglChooseConfig(display, config_attributes, &config, 1, &configs) != EGL_TRUE ||
        configs < 1)
        return makeError(ErrorCode::kUnsupported, eglFailure("eglChooseConfig"));
    // the debug attribute is EGL 1.5's: named only when asked for, so an EGL 1.4 with
    // KHR_create_context still makes a plain context
    EGLint context_attributes[] = {
        EGL_CONTEXT_MAJOR_VERSION,
        3,
        EGL_CONTEXT_MINOR_VERSION,
        3,
        EGL_CONTEXT_OPENGL_PROFILE_MASK,
        EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
        EGL_NONE,
        EGL_NONE,
        EGL_NONE};
    if (options.debug) {
        context_attributes[6] = EGL_CONTEXT_OPENGL_DEBUG;
        context_attributes[7] = EGL_TRUE;
    }
    c->context_ = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attributes);
    if (c->context_ == EGL_NO_CONTEXT)
        return makeError(ErrorCode::kUnsupported, eglFailure("eglCreateContext (3.3 core)"));
    if (!c->bindToThread())
        return makeError(ErrorCode::kUnsupported, eglFailure("eglMakeCurrent (no surface)"));
    c->makeCurrent();
    Status loaded = c->gl_.load(
        [](const char* name, void*) { return loaderPointer(eglGetProcAddress(name)); }, nullptr);
    if (!loaded)
        return loaded.error();
    c->attachDebugLog(options);

    // no window, so no default framebuffer: colour and depth renderbuffers stand in for it and
    // stay bound
    const GlApi& gl = c->gl_;
    gl.GenFramebuffers(1, &c->framebuffer_);
    gl.BindFramebuffer(GL_FRAMEBUFFER, c->framebuffer_);
    gl.GenRenderbuffers(1, &c->colour_);
    gl.BindRenderbuffer(GL_RENDERBUFFER, c->colour_);
    gl.RenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
    gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, c->colour_);
    gl.GenRenderbuffers(1, &c->depth_);
    gl.BindRenderbuffer(GL_RENDERBUFFER, c->depth_);
    gl.RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width, height);
    gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, c->depth_);
    if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        return makeError(ErrorCode::kUnsupported, "EGL: the offscreen framebuffer is incomplete");
    gl.ReadBuffer(GL_COLOR_ATTACHMENT0);
    return c;
}

bool EglContext::bindToThread() const {
    // glvnd skips eglMakeCurrent of the context it believes current; but an OSMesa context made
    // current since then took Mesa's dispatch (libglapi) away from it. Releasing first makes the
    // switch real.
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    return eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_) == EGL_TRUE;
}

EglContext::~EglContext() {
    forgetCurrent();
    if (context_ != nullptr) {
        if (framebuffer_ != 0 && bindToThread()) {
            pacer_.release(gl_);
            gl_.DeleteFramebuffers(1, &framebuffer_);
            gl_.DeleteRenderbuffers(1, &colour_);
            gl_.DeleteRenderbuffers(1, &depth_);
        }
        eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        eglDestroyContext(display_, context_);
    }
    // no eglTerminate: the surfaceless display is one per process, shared by every context
}

} // namespace terrain::render
