// Geomorphing (Tessellator::morphedHeights): where each vertex of a tile is drawn while its
// diamond's priority is inside the morph band, by a walk of the tile's split diamonds.

#include "tessellator_internal.h"

#include <terrain/assert.h>
#include <terrain/roam/tessellator.h>

#include <algorithm>

namespace terrain::roam {

using namespace detail;

struct Tessellator::MorphWalk {
    const ViewMetric* view = nullptr;
    std::int32_t tile = 0;
    double low = 0.0;      ///< the threshold: a vertex starts on its hypotenuse
    double inv_band = 0.0; ///< 1 / (full - low); 0: every vertex at its height
    std::span<double> drawn;
};

void Tessellator::morphedHeights(
    std::int32_t tile, const ViewMetric& view, double full_pixels, std::span<double> out) const {
    const auto count = static_cast<std::size_t>(tileVertexCount(tile));
    TERRAIN_ASSERT(out.size() == count);
    if (morph_stamp_.size() < count)
        morph_stamp_.resize(count, 0);
    if (++morph_call_ == 0) { // wrapped: old stamps could pass for new ones
        std::fill(morph_stamp_.begin(), morph_stamp_.end(), 0);
        morph_call_ = 1;
    }
    MorphWalk walk;
    walk.view = &view;
    walk.tile = tile;
    const double threshold = policy_.threshold();
    walk.low = threshold;
    walk.inv_band = full_pixels > threshold ? 1.0 / (full_pixels - threshold) : 0.0;
    walk.drawn = out;
    const Diamond root = tileRoot(tile);
    for (const LatticePoint a : apexes(root)) {
        const Triangle t = triangleOf(root, a);
        if (!emitted(t))
            continue;
        // the tile's corners are roots: always at their height
        Corners z{};
        const std::array<LatticePoint, 3> corners = {t.apex, t.left, t.right};
        for (std::size_t i = 0; i < 3; ++i) {
            const MeshVertex v = vertexAt(corners[i], t, tile);
            z[i] = static_cast<double>(v.height) * metres_per_fine_;
            out[v.index] = z[i];
        }
        morphBelow(walk, t, z, z);
    }
}

void Tessellator::morphBelow(
    MorphWalk& walk, const Triangle& t, const Corners& drawn, const Corners& z) const {
    if (t.level >= kFinestTriangleLevel)
        return;
    const LatticePoint c = splitPoint(t);
    const DiamondId id = idOf(c);
    if (!active(id))
        return;
    const auto halves = splitTriangle(t);
    if (t.level == kCellTriangleLevel) {
        // finer triangles use the copies of the cell's corners in its block
        walk.drawn[vertexIndex(t.apex, halves[0], walk.tile)] = drawn[0];
        walk.drawn[vertexIndex(t.left, halves[0], walk.tile)] = drawn[1];
        walk.drawn[vertexIndex(t.right, halves[0], walk.tile)] = drawn[2];
    }
    // a vertex on a cell's border has a copy in each cell's block, each one's triangles write
    // their own; the diamond's other triangle (this tile or another) finds the same ends: the
    // same arithmetic on the same values, so the same height everywhere
    const MeshVertex centre = vertexAt(c, halves[0], walk.tile);
    const double zc = static_cast<double>(centre.height) * metres_per_fine_;
    if (morph_stamp_[centre.index] != morph_call_) {
        morph_stamp_[centre.index] = morph_call_;
        const Bounds b = bounds(id);
        const Box box = boxOf(diamondAt(c), b);
        const double priority =
            box.lo.x > box.hi.x ? 0.0 : walk.view->screenErrorAnyDirection(box, b.delta);
        const double s = walk.inv_band == 0.0
                             ? 1.0
                             : std::clamp((priority - walk.low) * walk.inv_band, 0.0, 1.0);
        walk.drawn[centre.index] = (drawn[1] + drawn[2]) * 0.5 + s * (zc - (z[1] + z[2]) * 0.5);
    }
    const double dc = walk.drawn[centre.index];
    if (emitted(halves[0]))
        morphBelow(walk, halves[0], {dc, drawn[0], drawn[1]}, {zc, z[0], z[1]});
    if (emitted(halves[1]))
        morphBelow(walk, halves[1], {dc, drawn[2], drawn[0]}, {zc, z[2], z[0]});
}

} // namespace terrain::roam
