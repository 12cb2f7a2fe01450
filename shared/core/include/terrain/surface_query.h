#pragma once

// Height, normal and ray queries against the true surface: base triangles where a cell has no
// patch, the B-spline patch where it has one. Results are floats (metres); state is untouched.
// World frame: x along vertex columns, y along vertex rows, z up, all in metres, vertex (0, 0) at
// the origin. Pure: no I/O.

#include <terrain/terrain.h>

#include <glm/vec3.hpp>

#include <optional>

namespace terrain {

/// Height in metres at (x, y) metres; positions outside the map are clamped to its edge.
double surfaceHeight(const Terrain& t, double x, double y);

/// Unit upward normal at (x, y) metres (analytic on patches, per-triangle on base cells).
glm::dvec3 surfaceNormal(const Terrain& t, double x, double y);

struct RayHit {
    double distance = 0.0; ///< along the ray, in units of |direction| (metres if unit length)
    glm::dvec3 point{0.0};
    glm::dvec3 normal{0.0, 0.0, 1.0};
    std::int32_t cell_x = 0;
    std::int32_t cell_y = 0;
};

/// First intersection of origin + s * direction, 0 <= s <= max_distance, with the surface over the
/// map. Cells are walked in ray order (2D DDA); base cells are intersected exactly, patch cells by
/// sign search on a fine subdivision of the segment (split at the knot lines) and bisection to
/// 1e-9 of the cell size. Returns nothing if the ray misses, or if direction is zero/not finite.
std::optional<RayHit> castRay(
    const Terrain& t, const glm::dvec3& origin, const glm::dvec3& direction, double max_distance);

} // namespace terrain
