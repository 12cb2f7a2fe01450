#include "tile_vertex_builder.h"

#include <terrain/surface_query.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain::render {

std::uint32_t packNormal(double nx, double ny, double nz) {
    const auto component = [](double v, int shift) {
        const auto q = static_cast<std::int32_t>(std::lround(std::clamp(v, -1.0, 1.0) * 511.0));
        return (static_cast<std::uint32_t>(q) & 0x3ffu) << shift;
    };
    return component(nx, 0) | component(ny, 10) | component(nz, 20);
}

namespace {

/// A smooth normal from the true surface: central differences over the vertex's own grid step
/// (a cell on the base grid, a lattice step inside a detail block), one-sided at the map's
/// edge, where the surface is clamped.
std::uint32_t
normalAt(const Terrain& terrain, const roam::TileVertex& v, bool on_base_grid, double per_lattice) {
    const WorldSpec& spec = terrain.spec();
    const double spacing = spec.spacingMetres();
    double dzdx = 0.0;
    double dzdy = 0.0;
    if (on_base_grid) {
        // on the base grid the surface at the neighbouring vertices is their sample (patch
        // corners are pinned to them): read the samples, no surface queries; the padding takes
        // the map edge's slope
        const std::int32_t gx = std::min(v.position.x / roam::kLatticePerCell, spec.width - 1);
        const std::int32_t gy = std::min(v.position.y / roam::kLatticePerCell, spec.height - 1);
        const std::int32_t ax = std::max(gx - 1, 0);
        const std::int32_t bx = std::min(gx + 1, spec.width - 1);
        const std::int32_t ay = std::max(gy - 1, 0);
        const std::int32_t by = std::min(gy + 1, spec.height - 1);
        const double unit = spec.metresPerUnit();
        if (bx > ax)
            dzdx = (terrain.sample(bx, gy) - terrain.sample(ax, gy)) * unit / ((bx - ax) * spacing);
        if (by > ay)
            dzdy = (terrain.sample(gx, by) - terrain.sample(gx, ay)) * unit / ((by - ay) * spacing);
    } else {
        const double x = v.position.x * per_lattice;
        const double y = v.position.y * per_lattice;
        const double step = per_lattice;
        const double x0 = std::max(x - step, 0.0);
        const double x1 = std::min(x + step, spec.extentX());
        const double y0 = std::max(y - step, 0.0);
        const double y1 = std::min(y + step, spec.extentY());
        if (x1 > x0)
            dzdx = (surfaceHeight(terrain, x1, y) - surfaceHeight(terrain, x0, y)) / (x1 - x0);
        if (y1 > y0)
            dzdy = (surfaceHeight(terrain, x, y1) - surfaceHeight(terrain, x, y0)) / (y1 - y0);
    }
    const double inv = 1.0 / std::sqrt(dzdx * dzdx + dzdy * dzdy + 1.0);
    return packNormal(-dzdx * inv, -dzdy * inv, inv);
}

} // namespace

void TileVertexBuilder::build(
    const roam::Tessellator& tess,
    const Terrain& terrain,
    std::int32_t tile,
    std::span<const GpuVertex> previous,
    std::span<const LatticeRegion> changed,
    std::vector<GpuVertex>& out) {
    const double per_lattice = tess.metresPerLattice();
    const double per_fine = tess.metresPerFineUnit();
    const auto count = static_cast<std::uint32_t>(tess.tileVertexCount(tile));
    const auto old_count = static_cast<std::uint32_t>(previous.size());
    keys_.resize(count);
    out.resize(count);
    tess.tileVertices(tile, keys_);

    // Positions first (cheap). A vertex new to its slot (a grain came, or took a hole) needs
    // its own normal. Where one rose or fell in place, the surface changed, and so may every
    // normal within one cell of it (the surface changes only where some vertex did: every patch
    // cell has a detail block), as may the normals in the changed regions.
    roam::LatticePoint lo{
        std::numeric_limits<std::int32_t>::max(), std::numeric_limits<std::int32_t>::max()};
    roam::LatticePoint hi{
        std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::min()};
    for (std::uint32_t i = 0; i < count; ++i) {
        const roam::TileVertex& v = keys_[i];
        GpuVertex& o = out[i];
        // lattice units from the map's corner: whole numbers below 2^24, exact in a float, so
        // every copy of a vertex (tiles, cell blocks) is the same bits
        o.x = static_cast<float>(v.position.x);
        o.y = static_cast<float>(v.position.y);
        o.z = static_cast<float>(static_cast<double>(v.height) * per_fine);
        const bool fresh = i >= old_count || o.x != previous[i].x || o.y != previous[i].y;
        const bool moved = !fresh && o.z != previous[i].z;
        if (moved) {
            lo = {std::min(lo.x, v.position.x), std::min(lo.y, v.position.y)};
            hi = {std::max(hi.x, v.position.x), std::max(hi.y, v.position.y)};
        }
        o.normal = fresh || moved ? 0u : previous[i].normal;
    }
    constexpr std::int32_t kStencil = roam::kLatticePerCell;
    const LatticeRegion stencil{
        {lo.x - kStencil, lo.y - kStencil}, {hi.x + kStencil, hi.y + kStencil}};
    for (std::uint32_t i = 0; i < count; ++i) {
        const roam::LatticePoint p = keys_[i].position;
        const bool needed =
            out[i].normal == 0u || stencil.contains(p) ||
            std::any_of(changed.begin(), changed.end(), [&](const LatticeRegion& r) {
                return r.contains(p);
            });
        if (needed)
            out[i].normal = normalAt(
                terrain, keys_[i], i < static_cast<std::uint32_t>(roam::kTileBaseVertices),
                per_lattice);
    }
}

} // namespace terrain::render
