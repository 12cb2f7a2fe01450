#pragma once

// Measures of a drawn mesh against the true surface, for any method's triangles (world metres):
// the screen error (roam::measureScreenError's measure, generalised: every triangle sampled on a
// barycentric grid about samples_per_cell points per cell of edge length, each point and the
// true surface under it projected, the pixel distance taken), and the open edges of a mesh
// (edges of a single triangle inside the map: cracks or T-junctions). Pure.

#include <terrain/lodlab/lod_method.h>
#include <terrain/roam/camera.h>
#include <terrain/terrain.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace terrain::lodlab {

struct ScreenErrorOptions {
    double samples_per_cell = 2.0;
    int min_samples_per_edge = 2;
    double tau_pixels = 1.0; ///< triangles whose worst sample exceeds it are counted
};

struct MeshError {
    std::int64_t triangles = 0; ///< measured (with a visible sample)
    std::int64_t samples = 0;
    double max_pixels = 0.0;
    /// 99th percentile of the triangles' worst samples (nearest rank)
    double p99_pixels = 0.0;
    double mean_pixels = 0.0; ///< over samples
    std::int64_t triangles_over_tau = 0;
};

MeshError measureMeshError(
    std::span<const glm::dvec3> triangles,
    const Terrain& terrain,
    const roam::Camera& camera,
    const ScreenErrorOptions& options);

/// Edges used by one triangle only whose midpoint lies strictly inside the map, [0, max_x] x
/// [0, max_y] in the triangles' units (what lies on or beyond its border is clipped when
/// drawn): 0 for a conforming mesh.
std::int64_t
countOpenEdges(std::span<const LatticeTriangle> triangles, std::int64_t max_x, std::int64_t max_y);

} // namespace terrain::lodlab
