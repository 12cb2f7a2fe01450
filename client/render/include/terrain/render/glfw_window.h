#pragma once

// A GLFW window with an OpenGL 3.3 core context (X11; under Xvfb on a headless machine).

#include <terrain/render/gl_context.h>

#include <memory>
#include <string>

struct GLFWwindow;

namespace terrain::render {

class GlfwWindow final : public GlContext {
  public:
    /// Errors: kUnsupported when GLFW cannot start (no DISPLAY: the message says so) or gives
    /// no 3.3 core context; kOutOfRange for a size outside 1..16384.
    static Result<std::unique_ptr<GlfwWindow>> create(
        int width,
        int height,
        const std::string& title,
        bool vsync,
        const ContextOptions& options = {});
    ~GlfwWindow() override;
    GlfwWindow(const GlfwWindow&) = delete;
    GlfwWindow& operator=(const GlfwWindow&) = delete;

    const GlApi& gl() const override { return gl_; }
    int width() const override;
    int height() const override;
    void present() override;

    GLFWwindow* handle() const { return window_; }
    bool shouldClose() const;

  protected:
    bool bindToThread() const override;

  private:
    GlfwWindow() = default;
    GLFWwindow* window_ = nullptr;
    GlApi gl_;
};

} // namespace terrain::render
