#pragma once

// Measures what the tessellator promises, independently of its own bounds: the screen-space
// distance between the drawn mesh and the true surface (surfaceHeight: patches included),
// sampled densely over every drawn triangle of the tiles in view.
// Pure: reads the tessellator's output and the terrain; no GL.

#include <terrain/roam/camera.h>
#include <terrain/roam/tessellator.h>
#include <terrain/terrain.h>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>

namespace terrain::roam {

/// One triangle (world metres) against the true surface: sampled on a barycentric grid of n
/// steps per edge, n = max(min_samples_per_edge, ceil(longest edge / cell * samples_per_cell)),
/// each point and the surface under it projected; points beyond the map (its padding, clipped
/// when drawn) or off screen are skipped. Any mesh's measure builds on it (lodlab's too).
struct TriangleError {
    double worst_pixels = -1.0; ///< -1: no sample was visible
    glm::dvec3 worst_point{0.0};
    std::int64_t samples = 0;
    double sum_pixels = 0.0;
};
TriangleError measureTriangle(
    const ViewMetric& view,
    const Terrain& terrain,
    const std::array<glm::dvec3, 3>& v,
    int min_samples_per_edge,
    double samples_per_cell);

struct ScreenErrorOptions {
    /// Samples per triangle edge: at least this many, and at least this many per cell of edge
    /// length times samples_per_cell (so coarse triangles are sampled at every half cell).
    int min_samples_per_edge = 6;
    double samples_per_cell = 2.0;
};

struct ScreenErrorStats {
    double max_pixels = 0.0;
    /// Over triangles coarser than the finest level only. The finest triangles (1/16 cell, the
    /// patch grid) cannot be split further: where a patch's grid_error_bound seen from close by
    /// exceeds tau, the model itself is too coarse, and only these are bound by tau.
    double max_pixels_above_finest = 0.0;
    std::int64_t finest_triangles_over_tau_bound = 0; ///< finest triangles with a sample > tau
    double mean_pixels = 0.0;
    std::int64_t samples = 0;   ///< sample points inside the viewport
    std::int64_t triangles = 0; ///< drawn triangles examined
    glm::dvec3 worst_point{0.0};
};

ScreenErrorStats measureScreenError(
    const Tessellator& tessellator,
    const Terrain& terrain,
    const Camera& camera,
    const ScreenErrorOptions& options = {});

} // namespace terrain::roam
