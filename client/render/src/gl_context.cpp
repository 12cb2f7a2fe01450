#include <terrain/render/gl_context.h>

#include <cstdio>
#include <cstring>

namespace terrain::render {

namespace {
std::string glString(const GlApi& gl, GLenum name) {
    const GLubyte* s = gl.GetString(name);
    return s == nullptr ? std::string("?") : std::string(reinterpret_cast<const char*>(s));
}
} // namespace

namespace {
// the context this thread made current through makeCurrent()
thread_local const GlContext* current_context = nullptr;
} // namespace

void GlContext::makeCurrent() const {
    if (current_context == this)
        return;
    if (bindToThread())
        current_context = this;
}

void GlContext::forgetCurrent() const {
    if (current_context == this)
        current_context = nullptr;
}

bool GlContext::attachDebugLog(const ContextOptions& options) {
    if (!options.debug)
        return true;
    auto log = std::make_unique<GlDebugLog>();
    if (!log->attach(gl())) {
        std::fprintf(stderr, "GL debug output unavailable: the context has no KHR_debug\n");
        return false;
    }
    debug_log_ = std::move(log);
    return true;
}

std::string GlContext::describe() const {
    makeCurrent();
    return glString(gl(), GL_RENDERER) + " / OpenGL " + glString(gl(), GL_VERSION);
}

io::RgbImage GlContext::readPixels() const {
    makeCurrent();
    const GlApi& g = gl();
    io::RgbImage image;
    image.width = width();
    image.height = height();
    const auto row = static_cast<std::size_t>(image.width) * 3;
    std::vector<std::uint8_t> bottom_up(row * static_cast<std::size_t>(image.height));
    g.Finish();
    g.PixelStorei(GL_PACK_ALIGNMENT, 1);
    g.ReadPixels(0, 0, image.width, image.height, GL_RGB, GL_UNSIGNED_BYTE, bottom_up.data());
    // GL rows run bottom-up; images top-down
    image.rgb.resize(bottom_up.size());
    for (std::int32_t y = 0; y < image.height; ++y)
        std::memcpy(
            image.rgb.data() + static_cast<std::size_t>(y) * row,
            bottom_up.data() + static_cast<std::size_t>(image.height - 1 - y) * row, row);
    return image;
}

} // namespace terrain::render
