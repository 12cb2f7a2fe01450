#pragma once

// Compiles and links a vertex + fragment program; the error carries the GL's log.

#include <terrain/render/gl_api.h>

namespace terrain::render {

/// Attribute locations are fixed in the sources (layout qualifiers).
Result<unsigned>
buildProgram(const GlApi& gl, const char* vertex_source, const char* fragment_source);

} // namespace terrain::render
