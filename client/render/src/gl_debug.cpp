#include <terrain/render/gl_debug.h>

#include <cstdio>

namespace terrain::render {

namespace {

const char* severityName(unsigned severity) {
    switch (severity) {
    case GL_DEBUG_SEVERITY_HIGH:
        return "high";
    case GL_DEBUG_SEVERITY_MEDIUM:
        return "medium";
    case GL_DEBUG_SEVERITY_LOW:
        return "low";
    default:
        return "note";
    }
}

const char* typeName(unsigned type) {
    switch (type) {
    case GL_DEBUG_TYPE_ERROR:
        return "error";
    case GL_DEBUG_TYPE_DEPRECATED_BEHAVIOR:
        return "deprecated";
    case GL_DEBUG_TYPE_UNDEFINED_BEHAVIOR:
        return "undefined-behaviour";
    case GL_DEBUG_TYPE_PORTABILITY:
        return "portability";
    case GL_DEBUG_TYPE_PERFORMANCE:
        return "performance";
    default:
        return "other";
    }
}

void APIENTRY onMessage(
    GLenum source,
    GLenum type,
    GLuint id,
    GLenum severity,
    GLsizei length,
    const GLchar* message,
    const void* user) {
    auto* log = static_cast<GlDebugLog*>(const_cast<void*>(user));
    const std::string text =
        length >= 0 ? std::string(message, static_cast<std::size_t>(length)) : std::string(message);
    log->receive(source, type, id, severity, text);
}

} // namespace

bool GlDebugLog::attach(const GlApi& gl) {
    if (gl.DebugMessageCallback == nullptr || gl.DebugMessageControl == nullptr ||
        (gl.version() < 43 && !gl.hasExtension("GL_KHR_debug")))
        return false;
    gl.Enable(GL_DEBUG_OUTPUT);
    gl.Enable(GL_DEBUG_OUTPUT_SYNCHRONOUS);
    gl.DebugMessageCallback(onMessage, this);
    // everything, notifications included: a driver's notes on where buffers live are wanted
    gl.DebugMessageControl(GL_DONT_CARE, GL_DONT_CARE, GL_DONT_CARE, 0, nullptr, GL_TRUE);
    attached_ = true;
    return true;
}

void GlDebugLog::receive(
    unsigned source, unsigned type, unsigned id, unsigned severity, const std::string& text) {
    (void)source;
    ++messages_;
    if (type == GL_DEBUG_TYPE_ERROR)
        ++errors_;
    char head[96];
    std::snprintf(head, sizeof head, "GL %s %s 0x%x: ", severityName(severity), typeName(type), id);
    std::string line = head + text;
    while (!line.empty() && (line.back() == '\n' || line.back() == '\r'))
        line.pop_back();
    if (kept_.size() < kKeptLines)
        kept_.push_back(line);
    if (sink_)
        sink_(line);
    else
        std::fprintf(stderr, "%s\n", line.c_str());
}

} // namespace terrain::render
