// terrain-viewer: fly over a live terrain server's world and blast craters into it.
//   terrain-viewer                                   serve a procedural map in-process, join it
//   terrain-viewer --connect host:7777 --token T     join a running terrain-server
// Scripted runs (tests): --frames N --fly --auto-crater K --screenshot a.png --report r.json
// Keys: client/viewer/README.md.

#include "src/viewer_app.h"

#include <terrain/viewer/viewer_options.h>

#include <CLI/CLI.hpp>

#include <cstdio>

int main(int argc, char** argv) {
    using namespace terrain::viewer;
    ViewerOptions options;
    CLI::App app{"terrain-viewer: an interactive view of a terrain server's world"};
    addViewerOptions(app, options);
    CLI11_PARSE(app, argc, argv);
    if (terrain::Status s = finishViewerOptions(options); !s) {
        std::fprintf(stderr, "terrain-viewer: %s\n", s.error().message.c_str());
        return 2;
    }
    std::setvbuf(stdout, nullptr, _IOLBF, 0);
    return runViewer(options);
}
