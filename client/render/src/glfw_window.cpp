#include <terrain/render/glfw_window.h>

#include <GLFW/glfw3.h>

#include <cstdlib>
#include <cstring>

namespace terrain::render {

namespace {
std::string lastGlfwError() {
    const char* description = nullptr;
    glfwGetError(&description);
    return description != nullptr ? description : "unknown GLFW error";
}
} // namespace

Result<std::unique_ptr<GlfwWindow>> GlfwWindow::create(
    int width, int height, const std::string& title, bool vsync, const ContextOptions& options) {
    if (width < 1 || height < 1 || width > 16384 || height > 16384)
        return makeError(
            ErrorCode::kOutOfRange, "window size " + std::to_string(width) + " x " +
                                        std::to_string(height) +
                                        " must be within 1..16384 per side");
    const char* display = std::getenv("DISPLAY");
    if (display == nullptr || *display == '\0')
        return makeError(
            ErrorCode::kUnsupported,
            "no DISPLAY: a window needs an X server (run under xvfb-run on a headless machine)");
    if (glfwInit() != GLFW_TRUE)
        return makeError(ErrorCode::kUnsupported, "glfwInit failed: " + lastGlfwError());
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_DEPTH_BITS, 24);
    glfwWindowHint(GLFW_OPENGL_DEBUG_CONTEXT, options.debug ? GLFW_TRUE : GLFW_FALSE);
    GLFWwindow* window = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
    if (window == nullptr) {
        const std::string why = lastGlfwError();
        glfwTerminate();
        return makeError(ErrorCode::kUnsupported, "no OpenGL 3.3 core window: " + why);
    }
    std::unique_ptr<GlfwWindow> w(new GlfwWindow());
    w->window_ = window;
    w->makeCurrent();
    glfwSwapInterval(vsync ? 1 : 0);
    Status loaded = w->gl_.load(
        [](const char* name, void*) { return loaderPointer(glfwGetProcAddress(name)); }, nullptr);
    if (!loaded)
        return loaded.error();
    w->attachDebugLog(options);
    return w;
}

bool GlfwWindow::bindToThread() const {
    glfwMakeContextCurrent(window_);
    return glfwGetCurrentContext() == window_;
}

GlfwWindow::~GlfwWindow() {
    forgetCurrent();
    if (window_ != nullptr) {
        glfwDestroyWindow(window_);
        glfwTerminate();
    }
}

int GlfwWindow::width() const {
    int w = 0;
    int h = 0;
    glfwGetFramebufferSize(window_, &w, &h);
    return w;
}

int GlfwWindow::height() const {
    int w = 0;
    int h = 0;
    glfwGetFramebufferSize(window_, &w, &h);
    return h;
}

void GlfwWindow::present() {
    glfwSwapBuffers(window_);
}

bool GlfwWindow::shouldClose() const {
    return glfwWindowShouldClose(window_) != 0;
}

} // namespace terrain::render
