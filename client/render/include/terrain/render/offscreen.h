#pragma once

// An offscreen context by backend name, for programs and tests that let the user choose.

#include <terrain/render/gl_context.h>

#include <memory>
#include <string>

namespace terrain::render {

enum class OffscreenBackend { kOsmesa, kEgl };

/// "osmesa" or "egl"; errors: kOutOfRange naming the accepted names.
Result<OffscreenBackend> parseOffscreenBackend(const std::string& name);
const char* toString(OffscreenBackend backend);

/// The backend's context, current on this thread (see OsmesaContext::create, EglContext::create).
Result<std::unique_ptr<GlContext>> createOffscreenContext(
    OffscreenBackend backend, int width, int height, const ContextOptions& options = {});

} // namespace terrain::render
