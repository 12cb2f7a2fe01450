#include <terrain/render/egl_context.h>
#include <terrain/render/offscreen.h>
#include <terrain/render/osmesa_context.h>

namespace terrain::render {

Result<OffscreenBackend> parseOffscreenBackend(const std::string& name) {
    if (name == "osmesa")
        return OffscreenBackend::kOsmesa;
    if (name == "egl")
        return OffscreenBackend::kEgl;
    return makeError(
        ErrorCode::kOutOfRange, "offscreen backend must be 'osmesa' or 'egl', got '" + name + "'");
}

const char* toString(OffscreenBackend backend) {
    return backend == OffscreenBackend::kOsmesa ? "osmesa" : "egl";
}

Result<std::unique_ptr<GlContext>> createOffscreenContext(
    OffscreenBackend backend, int width, int height, const ContextOptions& options) {
    if (backend == OffscreenBackend::kOsmesa) {
        auto c = OsmesaContext::create(width, height, options);
        if (!c)
            return c.error();
        return std::unique_ptr<GlContext>(std::move(*c));
    }
    auto c = EglContext::create(width, height, options);
    if (!c)
        return c.error();
    return std::unique_ptr<GlContext>(std::move(*c));
}

} // namespace terrain::render
