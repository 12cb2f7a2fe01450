#pragma once

// The Dear ImGui overlay: what the frame cost and whether the world is verified, plus the few
// controls worth changing live (tau, draw mode, crater size, speed). ImGui's own GLFW and
// OpenGL 3 backends draw it (they load GL through their own loader, which is fine with the
// window's GLX context); only this file touches ImGui.

#include <terrain/result.h>

#include <cstdint>
#include <memory>
#include <string>

struct GLFWwindow;

namespace terrain::viewer {

/// What the overlay shows this frame.
struct OverlayView {
    std::string server; ///< host:port
    bool in_process = false;
    std::string renderer;
    std::string status; ///< "verified", "diverged", "joining", ...
    std::uint64_t seq = 0;
    std::uint64_t verified_seq = 0;
    std::uint64_t world_hash = 0;
    double rtt_ms = 0.0;
    std::int64_t triangles = 0;
    std::int64_t visible_triangles = 0;
    double tessellation_ms = 0.0; ///< median of the last 60 frames
    double draw_ms = 0.0;         ///< sync + draw (CPU), median of the last 60
    double gpu_ms = 0.0;          ///< the GPU's time for uploads and draws, median of 60
    double frame_ms = 0.0;
    std::uint64_t upload_bytes = 0; ///< this frame
    std::uint64_t upload_bytes_total = 0;
    std::int64_t craters_requested = 0;
    std::int64_t craters_accepted = 0;
    std::int64_t craters_refused = 0;
    double eye[3] = {0.0, 0.0, 0.0};
    std::string message; ///< the latest event worth a line (a refusal, a screenshot)
};

/// What the overlay lets the user change; read back every frame.
struct OverlayControls {
    float tau_pixels = 2.0f;
    int draw_mode = 0; ///< 0 shaded, 1 shaded + wireframe, 2 wireframe
    float crater_radius = 8.0f;
    float crater_depth = 3.0f;
    float speed = 40.0f; ///< metres per second
};

inline constexpr int kDrawModes = 3;

class ViewerOverlay {
  public:
    /// ImGui context and backends for `window` (its context current). Errors: kUnsupported when
    /// a backend cannot start.
    static Result<std::unique_ptr<ViewerOverlay>> create(GLFWwindow* window);
    ~ViewerOverlay();
    ViewerOverlay(const ViewerOverlay&) = delete;
    ViewerOverlay& operator=(const ViewerOverlay&) = delete;

    /// As of the last frame: the pointer or keys belong to the overlay, not to the terrain.
    bool wantsMouse() const;
    bool wantsKeyboard() const;

    /// Builds this frame's overlay and draws it over the framebuffer.
    void draw(const OverlayView& view, OverlayControls& controls);

  private:
    ViewerOverlay() = default;
    bool glfw_ready_ = false;
    bool gl_ready_ = false;
};

} // namespace terrain::viewer
