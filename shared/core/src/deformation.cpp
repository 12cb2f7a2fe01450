// Terrain::apply: one deformation op on base samples and detail patches.
//
// Order of work (fixed, so every replica reaches the same bits):
//  1. new base samples for the vertices inside the op's footprint box, from the old ones;
//  2. for each cell touching the box, row-major: the candidate surface (old patch, or the old base
//     triangles, with the op applied pointwise at the control points), and whether the new base
//     triangles hold it within the patch tolerance on the 17 x 17 grid;
//  3. border enforcement from a FIFO worklist: a patch border facing a cell without a patch is
//     put back on the straight base edge; a straightened patch that the base now holds within
//     tolerance is dropped, which queues its patched neighbours (one ring beyond the footprint at
//     most: cells outside are straightened but not re-judged until an op touches them);
//  4. commit, then rehash the tiles whose bytes changed.
// All arithmetic is integer, in 1/48 quanta (kFineScale), on int64.
// A pointwise op changes a patch by the control change whose spline interpolates the op's change
// at the 5 x 5 Greville points (cubic interpolation: exact for the quadratic crater bowl, O(h^4)
// elsewhere). The earlier Greville sampling (quasi-interpolation, O(h^2)) could not get a crater
// closer than about 3 cm on a 1 m grid whatever the tolerance. Ops smaller than half a cell keep
// the sampling: exact interpolation rings when a feature falls between the Greville points.
// (Clamping the interpolated change to the sampled range was measured and rejected: it doubled
// the rim error of ordinary craters.)

#include <terrain/base_cell.h>
#include <terrain/detail_patch.h>
#include <terrain/patch_decision.h>
#include <terrain/pointwise_op.h>
#include <terrain/terrain.h>

#include <algorithm>

namespace terrain {
namespace {

using bspline::kControls;
using bspline::kGrevilleSixths;
using bspline::kGridSamples;
using bspline::kGridSteps;

struct LocalCell {
    const DetailPatch* old = nullptr; // the patch before the op (looked up once)
    bool has = false;
    bool judged = false; // inside the footprint: may be dropped by the worklist
    DetailPatch patch;
};

bool isCorner(int i, int j) {
    return (i == 0 || i == kControls - 1) && (j == 0 || j == kControls - 1);
}

std::int32_t clampControl(std::int64_t c) {
    constexpr std::int64_t kLimit = kControlScale * kMaxHeightQuanta;
    return static_cast<std::int32_t>(std::clamp(c, -kLimit, kLimit));
}

} // namespace

Result<OpEffect> Terrain::apply(const DeformOp& op, TaskRunner* runner) {
    if (auto status = validateOp(op, spec_); !status)
        return status.error();

    const std::int64_t h = spec_.spacing;
    const std::int64_t h48 = h * kFineScale;
    const std::int64_t reach = footprintRadius(op);
    const std::int64_t tol = spec_.patch_tolerance;
    // craters survey the ground first: everything below reads the surface before the op
    const PointwiseOp f(op, *this);

    OpEffect effect;
    // vertices inside the footprint's box; only they can change
    CellRect& vr = effect.vertices;
    vr.x0 = static_cast<std::int32_t>(std::max<std::int64_t>(0, ceilDiv(op.center_x - reach, h)));
    vr.y0 = static_cast<std::int32_t>(std::max<std::int64_t>(0, ceilDiv(op.center_y - reach, h)));
    vr.x1 = static_cast<std::int32_t>(
        std::min<std::int64_t>(spec_.width - 1, floorDiv(op.center_x + reach, h)));
    vr.y1 = static_cast<std::int32_t>(
        std::min<std::int64_t>(spec_.height - 1, floorDiv(op.center_y + reach, h)));
    // cells meeting the box
    CellRect& cr = effect.cells;
    cr.x0 = static_cast<std::int32_t>(std::max<std::int64_t>(0, floorDiv(op.center_x - reach, h)));
    cr.y0 = static_cast<std::int32_t>(std::max<std::int64_t>(0, floorDiv(op.center_y - reach, h)));
    cr.x1 = static_cast<std::int32_t>(
        std::min<std::int64_t>(spec_.cellsX() - 1, floorDiv(op.center_x + reach, h)));
    cr.y1 = static_cast<std::int32_t>(
        std::min<std::int64_t>(spec_.cellsY() - 1, floorDiv(op.center_y + reach, h)));

    // 1. new base samples
    const std::int32_t vw = vr.empty() ? 0 : vr.x1 - vr.x0 + 1;
    const std::int32_t vh = vr.empty() ? 0 : vr.y1 - vr.y0 + 1;
    std::vector<std::int32_t> fresh(static_cast<size_t>(vw) * static_cast<size_t>(vh));
    for (std::int32_t y = vr.y0; y <= vr.y1; ++y)
        for (std::int32_t x = vr.x0; x <= vr.x1; ++x) {
            const std::int64_t z = sample(x, y);
            const std::int64_t x48 = x * h48;
            const std::int64_t y48 = y * h48;
            std::int64_t next = z;
            if (op.kind == OpKind::kSmooth) {
                const std::int64_t a = (fadeWeight(op, x48, y48) * op.strength) >> 16;
                if (a != 0) {
                    // 4-neighbour average of the old samples; the map edge mirrors the vertex
                    const std::int64_t sum = (x > 0 ? sample(x - 1, y) : z) +
                                             (x < spec_.width - 1 ? sample(x + 1, y) : z) +
                                             (y > 0 ? sample(x, y - 1) : z) +
                                             (y < spec_.height - 1 ? sample(x, y + 1) : z);
                    next = z + roundDiv((sum - 4 * z) * a, 4 * std::int64_t{kUnitStrength});
                }
            } else {
                next = roundDiv(
                    f.height(x48, y48, z * kFineScale, std::int64_t{original(x, y)} * kFineScale),
                    kFineScale);
            }
            fresh[static_cast<size_t>((y - vr.y0) * vw + (x - vr.x0))] = clampHeight(next);
        }
    auto newSample = [&](std::int32_t x, std::int32_t y) {
        if (x >= vr.x0 && x <= vr.x1 && y >= vr.y0 && y <= vr.y1)
            return fresh[static_cast<size_t>((y - vr.y0) * vw + (x - vr.x0))];
        return sample(x, y);
    };
    auto newCorners = [&](std::int32_t cx, std::int32_t cy) {
        return CellCorners{
            newSample(cx, cy), newSample(cx + 1, cy), newSample(cx, cy + 1),
            newSample(cx + 1, cy + 1)};
    };

    // the op applied to a patch's controls (corners are pinned afterwards). The pointwise kinds
    // see the old surface at the Greville points: a patch's exact heights there, or, for a patch
    // just made from the base cell, its controls (the triangles sampled there)
    auto transform = [&](DetailPatch& p, std::int32_t cx, std::int32_t cy, const CellCorners& co,
                         const CellCorners& cn, bool from_base) {
        std::array<std::int64_t, kPatchControls> old48{};
        if (op.kind != OpKind::kSmooth) {
            if (from_base)
                for (int c = 0; c < kPatchControls; ++c)
                    old48[static_cast<size_t>(c)] =
                        p.control[static_cast<size_t>(c)] * (kFineScale / kControlScale);
            else
                grevilleHeights48(p, old48);
        }
        // the original ground at the Greville points: the base triangles over its corners
        const CellCorners oc = originalCorners(cx, cy);
        const Diagonal od = cellDiagonal(cx, cy);
        std::array<std::int64_t, kPatchControls> change48{}; // pointwise ops: change at Greville
        for (int j = 0; j < kControls; ++j)
            for (int i = 0; i < kControls; ++i) {
                // Greville point g/6 of the cell, in 1/48 quanta: g * h * 8
                const std::int64_t gu = kGrevilleSixths[static_cast<size_t>(i)];
                const std::int64_t gv = kGrevilleSixths[static_cast<size_t>(j)];
                const std::int64_t x48 = cx * h48 + gu * h * (kFineScale / kControlScale);
                const std::int64_t y48 = cy * h48 + gv * h * (kFineScale / kControlScale);
                const std::int64_t c6 = p.at(i, j);
                if (op.kind == OpKind::kSmooth) {
                    if (isCorner(i, j))
                        continue;
                    // shrink the detail above the bilinear surface of the corners; a straight
                    // border has no detail and stays straight
                    const std::int64_t a = (fadeWeight(op, x48, y48) * op.strength) >> 16;
                    auto bilinear36 = [&](const CellCorners& c) {
                        return (6 - gu) * (6 - gv) * c.h00 + gu * (6 - gv) * c.h10 +
                               (6 - gu) * gv * c.h01 + gu * gv * c.h11;
                    };
                    const std::int64_t detail36 = 6 * c6 - bilinear36(co);
                    p.at(i, j) = clampControl(
                        roundDiv(bilinear36(cn) + ((detail36 * (kUnitStrength - a)) >> 16), 6));
                } else {
                    const std::int64_t z48 = old48[static_cast<size_t>(j * kControls + i)];
                    const std::int64_t o48 = (kFineScale / kControlScale) *
                                             baseHeightScaled(oc, od, gu, gv, kControlScale);
                    change48[static_cast<size_t>(j * kControls + i)] =
                        f.height(x48, y48, z48, o48) - z48;
                }
            }
        if (op.kind != OpKind::kSmooth) {
            // the control change that makes the spline interpolate the change at the 25 Greville
            // points (tensor product; one rounding at the end, every product below 2^53)
            std::array<std::int64_t, kPatchControls> rows{};
            for (int j = 0; j < kControls; ++j)
                for (int i = 0; i < kControls; ++i) {
                    std::int64_t sum = 0;
                    for (int k = 0; k < kControls; ++k)
                        sum += bspline::kInterpolation[static_cast<size_t>(i)]
                                                      [static_cast<size_t>(k)] *
                               change48[static_cast<size_t>(j * kControls + k)];
                    rows[static_cast<size_t>(j * kControls + i)] = sum;
                }
            // interpolation needs the op to span at least half a cell: a smaller feature falls
            // between the Greville points and the interpolant rings (a 2 km crater in a 10 km
            // cell swung controls by twice its depth); below that, sample the change at the
            // Greville points, which never overshoots (variation diminishing)
            const bool interpolate = 2 * std::int64_t{op.radius} >= h;
            constexpr std::int64_t kDivisor = bspline::kInterpolationScale *
                                              bspline::kInterpolationScale *
                                              (kFineScale / kControlScale);
            for (int j = 0; j < kControls; ++j)
                for (int i = 0; i < kControls; ++i) {
                    if (isCorner(i, j))
                        continue;
                    std::int64_t sum = 0;
                    for (int k = 0; k < kControls; ++k)
                        sum += bspline::kInterpolation[static_cast<size_t>(j)]
                                                      [static_cast<size_t>(k)] *
                               rows[static_cast<size_t>(k * kControls + i)];
                    const std::int64_t change =
                        interpolate ? roundDiv(sum, kDivisor)
                                    : roundDiv(
                                          change48[static_cast<size_t>(j * kControls + i)],
                                          kFineScale / kControlScale);
                    p.at(i, j) = clampControl(p.at(i, j) + change);
                }
        }
        pinCorners(p, cn);
    };

    // 2. judge every cell meeting the footprint; keep one more ring for border enforcement
    CellRect er{
        std::max(0, cr.x0 - 1), std::max(0, cr.y0 - 1), std::min(spec_.cellsX() - 1, cr.x1 + 1),
        std::min(spec_.cellsY() - 1, cr.y1 + 1)};
    const std::int32_t ew = er.x1 - er.x0 + 1;
    const std::int32_t eh = er.y1 - er.y0 + 1;
    std::vector<LocalCell> local(static_cast<size_t>(ew) * static_cast<size_t>(eh));
    auto inEr = [&](std::int32_t cx, std::int32_t cy) {
        return cx >= er.x0 && cx <= er.x1 && cy >= er.y0 && cy <= er.y1;
    };
    auto at = [&](std::int32_t cx, std::int32_t cy) -> LocalCell& {
        return local[static_cast<size_t>((cy - er.y0) * ew + (cx - er.x0))];
    };
    // the patches before the op: cells are row-major within a tile, so one binary search per
    // tile row rather than one per cell
    for (std::int32_t cy = er.y0; cy <= er.y1; ++cy)
        for (std::int32_t tx = er.x0 / kTileCells; tx <= er.x1 / kTileCells; ++tx) {
            const std::int32_t x0 = std::max(er.x0, tx * kTileCells);
            const std::int32_t x1 = std::min(er.x1, tx * kTileCells + kTileCells - 1);
            const std::span<const PatchEntry> patches = tilePatches(tileOfCell(x0, cy));
            const std::uint16_t last = localCell(x1, cy);
            auto it = std::lower_bound(
                patches.begin(), patches.end(), localCell(x0, cy),
                [](const PatchEntry& e, std::uint16_t c) { return e.cell < c; });
            for (; it != patches.end() && it->cell <= last; ++it) {
                LocalCell& cell = at(tx * kTileCells + it->cell % kTileCells, cy);
                cell.old = &it->patch;
                cell.has = true;
                cell.patch = it->patch;
            }
        }
    // each cell is judged from the state before the op into its own slot: rows in any order
    auto judgeRow = [&](std::size_t row) {
        const std::int32_t cy = cr.y0 + static_cast<std::int32_t>(row);
        for (std::int32_t cx = cr.x0; cx <= cr.x1; ++cx) {
            // a cell of the box that the footprint's disc misses keeps its patch as it is
            const std::int64_t nx = std::clamp(op.center_x, cx * h, (cx + 1) * h) - op.center_x;
            const std::int64_t ny = std::clamp(op.center_y, cy * h, (cy + 1) * h) - op.center_y;
            if (nx * nx + ny * ny >= reach * reach)
                continue;
            LocalCell& cell = at(cx, cy);
            cell.judged = true;
            const CellCorners co = corners(cx, cy);
            const CellCorners cn = newCorners(cx, cy);
            const Diagonal d = cellDiagonal(cx, cy);
            if (cell.has) {
                transform(cell.patch, cx, cy, co, cn, false);
                cell.has = patchNeeded(cell.patch, cn, d, tol);
            } else if (baseCellNeedsPatch(f, cx, cy, co, cn, originalCorners(cx, cy), h, tol)) {
                cell.patch = patchFromBase(co, d);
                transform(cell.patch, cx, cy, co, cn, true);
                cell.has = true;
            }
        }
    };
    if (!cr.empty())
        forEachTask(runner, static_cast<std::size_t>(cr.y1 - cr.y0 + 1), 4, judgeRow);

    // 3. borders facing base cells go straight; patches the base now holds are dropped
    std::vector<std::int32_t> queue;
    for (std::int32_t cy = er.y0; cy <= er.y1; ++cy)
        for (std::int32_t cx = er.x0; cx <= er.x1; ++cx)
            if (at(cx, cy).has)
                queue.push_back(cy * spec_.cellsX() + cx);
    for (std::size_t next = 0; next < queue.size(); ++next) {
        const std::int32_t cx = queue[next] % spec_.cellsX();
        const std::int32_t cy = queue[next] / spec_.cellsX();
        LocalCell& cell = at(cx, cy);
        if (!cell.has)
            continue;
        const CellCorners cn = newCorners(cx, cy);
        bool straightened = false;
        for (Edge e : kAllEdges) {
            const CellOffset off = neighbourOffset(e);
            const std::int32_t nx = cx + off.dx;
            const std::int32_t ny = cy + off.dy;
            if (nx < 0 || ny < 0 || nx >= spec_.cellsX() || ny >= spec_.cellsY())
                continue;
            const bool neighbour_has = inEr(nx, ny) ? at(nx, ny).has : findPatch(nx, ny) != nullptr;
            if (!neighbour_has && !isEdgeStraight(cell.patch, e, cn)) {
                straightenEdge(cell.patch, e, cn);
                straightened = true;
            }
        }
        if (straightened && cell.judged &&
            !patchNeeded(cell.patch, cn, cellDiagonal(cx, cy), tol)) {
            cell.has = false;
            for (Edge e : kAllEdges) {
                const CellOffset off = neighbourOffset(e);
                const std::int32_t nx = cx + off.dx;
                const std::int32_t ny = cy + off.dy;
                if (inEr(nx, ny) && at(nx, ny).has)
                    queue.push_back(ny * spec_.cellsX() + nx);
            }
        }
    }

    // 4. commit
    auto markVertexTiles = [&](std::int32_t x, std::int32_t y) {
        for (std::int32_t ty = std::max(0, (y - 1) / kTileCells);
             ty <= std::min(spec_.tilesY() - 1, y / kTileCells); ++ty)
            for (std::int32_t tx = std::max(0, (x - 1) / kTileCells);
                 tx <= std::min(spec_.tilesX() - 1, x / kTileCells); ++tx)
                effect.dirty_tiles.push_back(ty * spec_.tilesX() + tx);
    };
    for (std::int32_t y = vr.y0; y <= vr.y1; ++y)
        for (std::int32_t x = vr.x0; x <= vr.x1; ++x) {
            const std::int32_t z = fresh[static_cast<size_t>((y - vr.y0) * vw + (x - vr.x0))];
            if (z != sample(x, y)) {
                setSample(x, y, z);
                ++effect.vertices_changed;
                markVertexTiles(x, y);
            }
        }
    std::vector<PatchChange> changes;
    struct Bounded {
        std::size_t change;
        std::int32_t cx, cy;
    };
    std::vector<Bounded> bounded; // kept patches, bounded below over their new corners
    for (std::int32_t cy = er.y0; cy <= er.y1; ++cy)
        for (std::int32_t cx = er.x0; cx <= er.x1; ++cx) {
            LocalCell& cell = at(cx, cy);
            const DetailPatch* old = cell.old;
            if (old == nullptr && !cell.has)
                continue;
            if (old != nullptr && cell.has && old->control == cell.patch.control)
                continue;
            PatchChange change{tileOfCell(cx, cy), localCell(cx, cy), !cell.has, {}};
            if (cell.has) {
                (old == nullptr ? effect.patches_created : effect.patches_changed) += 1;
                change.patch = cell.patch;
                bounded.push_back({changes.size(), cx, cy});
            } else {
                ++effect.patches_removed;
            }
            changes.push_back(change);
            effect.dirty_tiles.push_back(change.tile);
            // border enforcement reaches one ring past the footprint's cells
            effect.cells = {
                std::min(effect.cells.x0, cx), std::min(effect.cells.y0, cy),
                std::max(effect.cells.x1, cx), std::max(effect.cells.y1, cy)};
        }
    forEachTask(runner, bounded.size(), 16, [&](std::size_t i) {
        const Bounded& b = bounded[i];
        updateBounds(changes[b.change].patch, corners(b.cx, b.cy));
    });
    std::sort(changes.begin(), changes.end(), [](const PatchChange& a, const PatchChange& b) {
        return a.tile != b.tile ? a.tile < b.tile : a.cell < b.cell;
    });
    applyPatchChanges(changes, runner);
    std::sort(effect.dirty_tiles.begin(), effect.dirty_tiles.end());
    effect.dirty_tiles.erase(
        std::unique(effect.dirty_tiles.begin(), effect.dirty_tiles.end()),
        effect.dirty_tiles.end());
    forEachTask(runner, effect.dirty_tiles.size(), 2, [&](std::size_t i) {
        rehashTile(effect.dirty_tiles[i]);
    });
    if (!effect.dirty_tiles.empty())
        rehashWorld();
    return effect;
}

} // namespace terrain
