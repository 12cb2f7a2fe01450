#pragma once

// Offscreen rendering through EGL with no window system (EGL_MESA_platform_surfaceless): an
// OpenGL 3.3 core context drawing into a framebuffer object of its own. The successor to
// OSMesa, which Mesa 25.1 removed; on a machine with a GPU driver's EGL it uses the GPU.

#include <terrain/render/frame_pacer.h>
#include <terrain/render/gl_context.h>

#include <memory>

namespace terrain::render {

class EglContext final : public GlContext {
  public:
    /// Errors: kUnsupported naming the EGL step that failed (no surfaceless platform, no 3.3
    /// core context, incomplete framebuffer); kOutOfRange for a size outside 1..8192.
    static Result<std::unique_ptr<EglContext>>
    create(int width, int height, const ContextOptions& options = {});
    ~EglContext() override;
    EglContext(const EglContext&) = delete;
    EglContext& operator=(const EglContext&) = delete;

    const GlApi& gl() const override { return gl_; }
    int width() const override { return width_; }
    int height() const override { return height_; }
    /// Submits the frame; waits only while more than FramePacer::kFramesInFlight are queued.
    void present() override { pacer_.frameDone(gl_); }

  protected:
    bool bindToThread() const override;

  private:
    EglContext() = default;
    void* display_ = nullptr;
    void* context_ = nullptr;
    int width_ = 0;
    int height_ = 0;
    unsigned framebuffer_ = 0;
    unsigned colour_ = 0;
    unsigned depth_ = 0;
    GlApi gl_;
    FramePacer pacer_;
};

} // namespace terrain::render
