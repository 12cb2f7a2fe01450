#pragma once

// Shaded-relief images of a terrain: hypsometric tint times Lambert shading from a low sun, with
// an optional tint on cells that carry a detail patch. The computation is pure; writing the PNG
// is png_image.h's job.

#include <terrain/io/png_image.h>
#include <terrain/terrain.h>

namespace terrain::io {

struct ReliefOptions {
    int pixels_per_cell = 1; ///< > 1 resolves the detail patches inside cells
    double sun_azimuth_degrees = 315.0;
    double sun_elevation_degrees = 40.0;
    double exaggeration = 1.0; ///< vertical exaggeration of the shading
    bool highlight_patches = false;
    /// Region in metres; an empty region (x1 <= x0) means the whole map.
    double x0 = 0.0;
    double y0 = 0.0;
    double x1 = 0.0;
    double y1 = 0.0;
    /// Height range of the colour ramp in metres; empty means the map's own range.
    double z_low = 0.0;
    double z_high = 0.0;
};

RgbImage renderShadedRelief(const Terrain& terrain, const ReliefOptions& options);

} // namespace terrain::io
