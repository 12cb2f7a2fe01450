#pragma once

// Where the renderer draws: an OpenGL 3.3 core context with its function table and a default
// framebuffer of a known size. Backends: GlfwWindow (a window, glfw_window.h) and
// OsmesaContext (offscreen, osmesa_context.h). An EGL surfaceless backend fits the same
// interface (newer Mesa drops OSMesa). A context is used from the thread that created it.

#include <terrain/io/png_image.h>
#include <terrain/render/gl_api.h>
#include <terrain/render/gl_debug.h>

#include <memory>
#include <string>

namespace terrain::render {

struct ContextOptions {
    /// A debug context (EGL_CONTEXT_OPENGL_DEBUG, GLFW_OPENGL_DEBUG_CONTEXT) with KHR_debug
    /// output routed to debugLog(): every driver message logged, errors counted.
    bool debug = false;
};

class GlContext {
  public:
    virtual ~GlContext() { forgetCurrent(); }

    virtual const GlApi& gl() const = 0;
    /// Framebuffer size in pixels (a window's may change between frames).
    virtual int width() const = 0;
    virtual int height() const = 0;
    /// Shows the frame (window) or waits until it is drawn (offscreen).
    virtual void present() = 0;

    /// Makes this context current on the calling thread unless it already is. Every context of
    /// a thread shares one GL dispatch (Mesa's libglapi), so whatever uses a context (the
    /// renderer, readPixels) calls this first: with two contexts alive, calls would otherwise
    /// reach whichever was made current last.
    void makeCurrent() const;

    /// "renderer / version" of the context, for logs and reports.
    std::string describe() const;
    /// The default framebuffer's colour, top row first (call before present() for a window).
    virtual io::RgbImage readPixels() const;

    /// The KHR_debug log of a context created with ContextOptions::debug whose GL has KHR_debug;
    /// null otherwise.
    GlDebugLog* debugLog() const { return debug_log_.get(); }

  protected:
    /// For a backend, once its context is current and loaded: a debug log if `options` ask.
    /// False if they do and the context lacks KHR_debug (then there is no log).
    bool attachDebugLog(const ContextOptions& options);
    /// The backend's make-current call; false if it failed.
    virtual bool bindToThread() const = 0;
    /// For destructors: this context is no longer current anywhere it was made current here.
    void forgetCurrent() const;

  private:
    std::unique_ptr<GlDebugLog> debug_log_;
};

} // namespace terrain::render
