#pragma once

// Where the renderer draws: an OpenGL 3.3 core context with its function table and a default
// framebuffer of a known size. Backends: GlfwWindow (a window, glfw_window.h) and
// OsmesaContext (offscreen, osmesa_context.h). An EGL surfaceless backend fits the same
// interface (newer Mesa drops OSMesa). A context is used from the thread that created it.

#include <terrain/io/png_image.h>
#include <terrain/render/gl_api.h>

#include <string>

namespace terrain::render {

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

  protected:
    /// The backend's make-current call; false if it failed.
    virtual bool bindToThread() const = 0;
    /// For destructors: this context is no longer current anywhere it was made current here.
    void forgetCurrent() const;
};

} // namespace terrain::render
