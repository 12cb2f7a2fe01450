#pragma once

// terrain-viewer's run: serve or join, open the window, fly, draw, report.

#include <terrain/viewer/viewer_options.h>

namespace terrain::viewer {

/// Runs until the window closes, Esc, or --frames. Returns the process exit code: 0 when the
/// replica ended verified, 1 when it could not join in time, diverged, or could not write its
/// outputs (the reason goes to stderr).
int runViewer(const ViewerOptions& options);

} // namespace terrain::viewer
