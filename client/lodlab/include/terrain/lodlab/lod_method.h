#pragma once

// The level-of-detail methods the speed-against-accuracy benchmark compares, behind one
// interface: our ROAM split/merge and split-only rebuild (roam::Tessellator), the full-resolution
// mesh (brute force: every base triangle, every patch cell at the lattice's 1/16 cell, culled by
// tile), and the chunked quadtree most engines ship (chunked_lod.h). Each frame reports what it
// draws and what it would upload; its triangles come out in world metres for the measures
// (screen_measure.h) and the reference renders. Pure: no GL, no clocks (the caller times
// update()).

#include <terrain/roam/camera.h>
#include <terrain/terrain.h>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace terrain::lodlab {

/// kSplitMergeMorph: split/merge refined to kMorphFraction * tau, its vertices geomorphed
/// (Tessellator::morphedHeights) so that the drawn surface is within tau at every instant.
enum class Method : std::uint8_t { kSplitMerge, kSplitOnly, kFullMesh, kChunked, kSplitMergeMorph };
inline constexpr std::array<Method, 5> kAllMethods = {
    Method::kSplitMerge, Method::kSplitOnly, Method::kFullMesh, Method::kChunked,
    Method::kSplitMergeMorph};
/// Where geomorphing refines (a share of tau): a vertex starts to slide at this share of tau
/// and reaches its height at tau.
inline constexpr double kMorphFraction = 0.5;

const char* toString(Method method);
std::optional<Method> parseMethod(const std::string& name);

struct MethodOptions {
    double tau_pixels = 1.0;
    std::int64_t max_triangles = 4'000'000;
};

struct MethodFrame {
    std::int64_t triangles = 0; ///< drawn (in view)
    std::int64_t upload_bytes = 0;
    /// The error every drawn triangle is within by the method's own bound (pixels): tau, or more
    /// where a cap or the method's finest level could not reach it; 0 for the full mesh.
    double error_bound_pixels = 0.0;
    bool rebuilt = false;        ///< ROAM: a top-down rebuild (teleport, cap)
    bool over_budget = false;    ///< ROAM: work left for later frames; chunked: the cap bound
    std::int64_t operations = 0; ///< splits + merges (ROAM), nodes visited (chunked), tiles
};

/// A triangle as three points in base-grid units scaled by 16 (the lattice: exact integers for
/// every method's vertices), for the crack count.
using LatticeTriangle = std::array<std::int64_t, 6>;

class LodMethod {
  public:
    virtual ~LodMethod() = default;
    virtual Method method() const = 0;
    virtual MethodFrame update(const roam::Camera& camera) = 0;
    /// The surface changed under `cells` (one rectangle per op) or everywhere.
    virtual void terrainChanged(std::span<const CellRect> cells, bool all) = 0;
    /// The drawn triangles (in view), world metres, three points each.
    virtual void visibleTriangles(std::vector<glm::dvec3>& out) const = 0;
    /// Every triangle of the current mesh, in view or not (cracks are counted on it).
    virtual void allTriangles(std::vector<LatticeTriangle>& out) const = 0;
    /// CPU memory of the method's state, bytes.
    virtual std::size_t memoryBytes() const = 0;
};

std::unique_ptr<LodMethod>
makeMethod(Method method, const Terrain& terrain, const MethodOptions& options);

} // namespace terrain::lodlab
