#pragma once

// Offscreen rendering with Mesa's OSMesa (llvmpipe on a machine without a GPU): an OpenGL 3.3
// core context drawing into memory. libOSMesa is opened at run time (dlopen, local symbols):
// linked in, its gl* exports would clash with glvnd's libGL in a process that also opens a
// window.

#include <terrain/render/frame_pacer.h>
#include <terrain/render/gl_context.h>

#include <memory>
#include <vector>

namespace terrain::render {

class OsmesaContext final : public GlContext {
  public:
    /// Errors: kUnsupported when libOSMesa.so.8 is missing or gives no 3.3 core context (the
    /// message says which), kOutOfRange for a size outside 1..8192.
    static Result<std::unique_ptr<OsmesaContext>>
    create(int width, int height, const ContextOptions& options = {});
    ~OsmesaContext() override;
    OsmesaContext(const OsmesaContext&) = delete;
    OsmesaContext& operator=(const OsmesaContext&) = delete;

    const GlApi& gl() const override { return gl_; }
    int width() const override { return width_; }
    int height() const override { return height_; }
    /// Submits the frame; waits only while more than FramePacer::kFramesInFlight are queued.
    void present() override { pacer_.frameDone(gl_); }
    /// Straight from the memory OSMesa draws into (complete after glFinish).
    io::RgbImage readPixels() const override;

  protected:
    bool bindToThread() const override;

  private:
    struct Library;
    OsmesaContext() = default;

    std::shared_ptr<Library> library_;
    void* context_ = nullptr;
    int width_ = 0;
    int height_ = 0;
    mutable std::vector<unsigned char> buffer_; // written by GL, not by this class
    GlApi gl_;
    FramePacer pacer_;
};

} // namespace terrain::render
