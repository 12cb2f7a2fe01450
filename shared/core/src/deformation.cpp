// Terrain::apply: one deformation op on base samples and detail patches.
//
// Order of work (fixed, so every replica reaches the same bits), one stage function each over
// an ApplyScratch:
//  0. measureFootprint: the vertices and cells the op's footprint box holds;
//  1. computeNewSamples: new base samples for those vertices, from the old ones;
//  2. judgeCells: for each cell touching the box, row-major: the candidate surface (old patch, or
//     the old base triangles, with the op applied pointwise at the control points:
//     transformPatch), and whether the new base triangles hold it within the patch tolerance on
//     the 17 x 17 grid;
//  3. enforceBorders, from a FIFO worklist: a patch border facing a cell without a patch is
//     put back on the straight base edge; a straightened patch that the base now holds within
//     tolerance is dropped, which queues its patched neighbours (one ring beyond the footprint at
//     most: cells outside are straightened but not re-judged until an op touches them);
//  4. commitOp, then rehash the tiles whose bytes changed.
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

// One op in flight: its footprint, the new samples and the cells it judged. Stage by stage,
// each stage reading what the ones before it wrote.
struct Terrain::ApplyScratch {
    const DeformOp& op;
    // craters survey the ground first: everything below reads the surface before the op
    const PointwiseOp f;
    std::int64_t h = 0;
    std::int64_t h48 = 0;
    std::int64_t reach = 0; // the footprint's radius
    std::int64_t tol = 0;
    OpEffect effect; // .vertices: the vertices that may change; .cells: the cells that may
    std::int32_t vw = 0;
    std::vector<std::int32_t> fresh; // new samples of effect.vertices, row-major
    CellRect er;                     // the judged cells and one ring more (border enforcement)
    std::int32_t ew = 0;
    std::vector<LocalCell> local; // per cell of er

    ApplyScratch(const DeformOp& o, const Terrain& t)
        : op(o), f(o, t), h(t.spec_.spacing), h48(h * kFineScale), reach(footprintRadius(o)),
          tol(t.spec_.patch_tolerance) {}

    std::int32_t newSample(const Terrain& t, std::int32_t x, std::int32_t y) const {
        const CellRect& vr = effect.vertices;
        if (x >= vr.x0 && x <= vr.x1 && y >= vr.y0 && y <= vr.y1)
            return fresh[static_cast<size_t>((y - vr.y0) * vw + (x - vr.x0))];
        return t.sample(x, y);
    }
    CellCorners newCorners(const Terrain& t, std::int32_t cx, std::int32_t cy) const {
        return CellCorners{
            newSample(t, cx, cy), newSample(t, cx + 1, cy), newSample(t, cx, cy + 1),
            newSample(t, cx + 1, cy + 1)};
    }
    bool inEr(std::int32_t cx, std::int32_t cy) const {
        return cx >= er.x0 && cx <= er.x1 && cy >= er.y0 && cy <= er.y1;
    }
    LocalCell& at(std::int32_t cx, std::int32_t cy) {
        return local[static_cast<size_t>((cy - er.y0) * ew + (cx - er.x0))];
    }
};

Result<OpEffect> Terrain::apply(const DeformOp& op, TaskRunner* runner) {
    if (auto status = validateOp(op, spec_); !status)
        return status.error();
    ApplyScratch s(op, *this);
    measureFootprint(s);
    computeNewSamples(s);
    judgeCells(s, runner);
    enforceBorders(s);
    commitOp(s, runner);
    return std::move(s.effect);
}

void Terrain::measureFootprint(ApplyScratch& s) const {
    const DeformOp& op = s.op;
    // vertices inside the footprint's box; only they can change
    CellRect& vr = s.effect.vertices;
    vr.x0 =
        static_cast<std::int32_t>(std::max<std::int64_t>(0, ceilDiv(op.center_x - s.reach, s.h)));
    vr.y0 =
        static_cast<std::int32_t>(std::max<std::int64_t>(0, ceilDiv(op.center_y - s.reach, s.h)));
    vr.x1 = static_cast<std::int32_t>(
        std::min<std::int64_t>(spec_.width - 1, floorDiv(op.center_x + s.reach, s.h)));
    vr.y1 = static_cast<std::int32_t>(
        std::min<std::int64_t>(spec_.height - 1, floorDiv(op.center_y + s.reach, s.h)));
    // cells meeting the box
    CellRect& cr = s.effect.cells;
    cr.x0 =
        static_cast<std::int32_t>(std::max<std::int64_t>(0, floorDiv(op.center_x - s.reach, s.h)));
    cr.y0 =
        static_cast<std::int32_t>(std::max<std::int64_t>(0, floorDiv(op.center_y - s.reach, s.h)));
    cr.x1 = static_cast<std::int32_t>(
        std::min<std::int64_t>(spec_.cellsX() - 1, floorDiv(op.center_x + s.reach, s.h)));
    cr.y1 = static_cast<std::int32_t>(
        std::min<std::int64_t>(spec_.cellsY() - 1, floorDiv(op.center_y + s.reach, s.h)));
}

// 1. new base samples
void Terrain::computeNewSamples(ApplyScratch& s) const {
    const DeformOp& op = s.op;
    const CellRect& vr = s.effect.vertices;
    s.vw = vr.empty() ? 0 : vr.x1 - vr.x0 + 1;
    const std::int32_t vh = vr.empty() ? 0 : vr.y1 - vr.y0 + 1;
    s.fresh.assign(static_cast<size_t>(s.vw) * static_cast<size_t>(vh), 0);
    for (std::int32_t y = vr.y0; y <= vr.y1; ++y)
        for (std::int32_t x = vr.x0; x <= vr.x1; ++x) {
            const std::int64_t z = sample(x, y);
            const std::int64_t x48 = x * s.h48;
            const std::int64_t y48 = y * s.h48;
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
                    s.f.height(x48, y48, z * kFineScale, std::int64_t{original(x, y)} * kFineScale),
                    kFineScale);
            }
            s.fresh[static_cast<size_t>((y - vr.y0) * s.vw + (x - vr.x0))] = clampHeight(next);
        }
}

// the op applied to a patch's controls (corners are pinned afterwards). The pointwise kinds
// see the old surface at the Greville points: a patch's exact heights there, or, for a patch
// just made from the base cell, its controls (the triangles sampled there)
void Terrain::transformPatch(
    const ApplyScratch& s,
    DetailPatch& p,
    std::int32_t cx,
    std::int32_t cy,
    const CellCorners& co,
    const CellCorners& cn,
    bool from_base) const {
    std::array<std::int64_t, kPatchControls> old48{};
    if (s.op.kind != OpKind::kSmooth) {
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
            const std::int64_t x48 = cx * s.h48 + gu * s.h * (kFineScale / kControlScale);
            const std::int64_t y48 = cy * s.h48 + gv * s.h * (kFineScale / kControlScale);
            const std::int64_t c6 = p.at(i, j);
            if (s.op.kind == OpKind::kSmooth) {
                if (isCorner(i, j))
                    continue;
                // shrink the detail above the bilinear surface of the corners; a straight
                // border has no detail and stays straight
                const std::int64_t a = (fadeWeight(s.op, x48, y48) * s.op.strength) >> 16;
                auto bilinear36 = [&](const CellCorners& c) {
                    return (6 - gu) * (6 - gv) * c.h00 + gu * (6 - gv) * c.h10 +
                           (6 - gu) * gv * c.h01 + gu * gv * c.h11;
                };
                const std::int64_t detail36 = 6 * c6 - bilinear36(co);
                p.at(i, j) = clampControl(
                    roundDiv(bilinear36(cn) + ((detail36 * (kUnitStrength - a)) >> 16), 6));
            } else {
                const std::int64_t z48 = old48[static_cast<size_t>(j * kControls + i)];
                const std::int64_t o48 =
                    (kFineScale / kControlScale) * baseHeightScaled(oc, od, gu, gv, kControlScale);
                change48[static_cast<size_t>(j * kControls + i)] =
                    s.f.height(x48, y48, z48, o48) - z48;
            }
        }
    if (s.op.kind != OpKind::kSmooth) {
        // the control change that makes the spline interpolate the change at the 25 Greville
        // points (tensor product; one rounding at the end, every product below 2^53)
        std::array<std::int64_t, kPatchControls> rows{};
        for (int j = 0; j < kControls; ++j)
            for (int i = 0; i < kControls; ++i) {
                std::int64_t sum = 0;
                for (int k = 0; k < kControls; ++k)
                    sum += bspline::kInterpolation[static_cast<size_t>(i)][static_cast<size_t>(k)] *
                           change48[static_cast<size_t>(j * kControls + k)];
                rows[static_cast<size_t>(j * kControls + i)] = sum;
            }
        // interpolation needs the op to span at least half a cell: a smaller feature falls
        // between the Greville points and the interpolant rings (a 2 km crater in a 10 km
        // cell swung controls by twice its depth); below that, sample the change at the
        // Greville points, which never overshoots (variation diminishing)
        const bool interpolate = 2 * std::int64_t{s.op.radius} >= s.h;
        constexpr std::int64_t kDivisor = bspline::kInterpolationScale *
                                          bspline::kInterpolationScale *
                                          (kFineScale / kControlScale);
        for (int j = 0; j < kControls; ++j)
            for (int i = 0; i < kControls; ++i) {
                if (isCorner(i, j))
                    continue;
                std::int64_t sum = 0;
                for (int k = 0; k < kControls; ++k)
                    sum += bspline::kInterpolation[static_cast<size_t>(j)][static_cast<size_t>(k)] *
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
}

// 2. judge every cell meeting the footprint; keep one more ring for border enforcement
void Terrain::judgeCells(ApplyScratch& s, TaskRunner* runner) const {
    const CellRect& cr = s.effect.cells;
    s.er = CellRect{
        std::max(0, cr.x0 - 1), std::max(0, cr.y0 - 1), std::min(spec_.cellsX() - 1, cr.x1 + 1),
        std::min(spec_.cellsY() - 1, cr.y1 + 1)};
    const CellRect& er = s.er;
    s.ew = er.x1 - er.x0 + 1;
    const std::int32_t eh = er.y1 - er.y0 + 1;
    s.local.assign(static_cast<size_t>(s.ew) * static_cast<size_t>(eh), LocalCell{});
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
                LocalCell& cell = s.at(tx * kTileCells + it->cell % kTileCells, cy);
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
            const std::int64_t nx =
                std::clamp(s.op.center_x, cx * s.h, (cx + 1) * s.h) - s.op.center_x;
            const std::int64_t ny =
                std::clamp(s.op.center_y, cy * s.h, (cy + 1) * s.h) - s.op.center_y;
            if (nx * nx + ny * ny >= s.reach * s.reach)
                continue;
            LocalCell& cell = s.at(cx, cy);
            cell.judged = true;
            const CellCorners co = corners(cx, cy);
            const CellCorners cn = s.newCorners(*this, cx, cy);
            const Diagonal d = cellDiagonal(cx, cy);
            if (cell.has) {
                transformPatch(s, cell.patch, cx, cy, co, cn, false);
                cell.has = patchNeeded(cell.patch, cn, d, s.tol);
            } else if (baseCellNeedsPatch(
                           s.f, cx, cy, co, cn, originalCorners(cx, cy), s.h, s.tol)) {
                cell.patch = patchFromBase(co, d);
                transformPatch(s, cell.patch, cx, cy, co, cn, true);
                cell.has = true;
            }
        }
    };
    if (!cr.empty())
        forEachTask(runner, static_cast<std::size_t>(cr.y1 - cr.y0 + 1), 4, judgeRow);
}

// 3. borders facing base cells go straight; patches the base now holds are dropped (a FIFO
// worklist: a dropped patch queues its patched neighbours)
void Terrain::enforceBorders(ApplyScratch& s) const {
    std::vector<std::int32_t> queue;
    for (std::int32_t cy = s.er.y0; cy <= s.er.y1; ++cy)
        for (std::int32_t cx = s.er.x0; cx <= s.er.x1; ++cx)
            if (s.at(cx, cy).has)
                queue.push_back(cy * spec_.cellsX() + cx);
    for (std::size_t next = 0; next < queue.size(); ++next) {
        const std::int32_t cx = queue[next] % spec_.cellsX();
        const std::int32_t cy = queue[next] / spec_.cellsX();
        LocalCell& cell = s.at(cx, cy);
        if (!cell.has)
            continue;
        const CellCorners cn = s.newCorners(*this, cx, cy);
        bool straightened = false;
        for (Edge e : kAllEdges) {
            const CellOffset off = neighbourOffset(e);
            const std::int32_t nx = cx + off.dx;
            const std::int32_t ny = cy + off.dy;
            if (nx < 0 || ny < 0 || nx >= spec_.cellsX() || ny >= spec_.cellsY())
                continue;
            const bool neighbour_has =
                s.inEr(nx, ny) ? s.at(nx, ny).has : findPatch(nx, ny) != nullptr;
            if (!neighbour_has && !isEdgeStraight(cell.patch, e, cn)) {
                straightenEdge(cell.patch, e, cn);
                straightened = true;
            }
        }
        if (straightened && cell.judged &&
            !patchNeeded(cell.patch, cn, cellDiagonal(cx, cy), s.tol)) {
            cell.has = false;
            for (Edge e : kAllEdges) {
                const CellOffset off = neighbourOffset(e);
                const std::int32_t nx = cx + off.dx;
                const std::int32_t ny = cy + off.dy;
                if (s.inEr(nx, ny) && s.at(nx, ny).has)
                    queue.push_back(ny * spec_.cellsX() + nx);
            }
        }
    }
}

// 4. commit: the samples, the patch changes (their bounds first), then the dirty tiles' hashes
void Terrain::commitOp(ApplyScratch& s, TaskRunner* runner) {
    const CellRect vr = s.effect.vertices;
    auto markVertexTiles = [&](std::int32_t x, std::int32_t y) {
        for (std::int32_t ty = std::max(0, (y - 1) / kTileCells);
             ty <= std::min(spec_.tilesY() - 1, y / kTileCells); ++ty)
            for (std::int32_t tx = std::max(0, (x - 1) / kTileCells);
                 tx <= std::min(spec_.tilesX() - 1, x / kTileCells); ++tx)
                s.effect.dirty_tiles.push_back(ty * spec_.tilesX() + tx);
    };
    for (std::int32_t y = vr.y0; y <= vr.y1; ++y)
        for (std::int32_t x = vr.x0; x <= vr.x1; ++x) {
            const std::int32_t z = s.fresh[static_cast<size_t>((y - vr.y0) * s.vw + (x - vr.x0))];
            if (z != sample(x, y)) {
                setSample(x, y, z);
                ++s.effect.vertices_changed;
                markVertexTiles(x, y);
            }
        }
    std::vector<PatchChange> changes;
    struct Bounded {
        std::size_t change;
        std::int32_t cx, cy;
    };
    std::vector<Bounded> bounded; // kept patches, bounded below over their new corners
    for (std::int32_t cy = s.er.y0; cy <= s.er.y1; ++cy)
        for (std::int32_t cx = s.er.x0; cx <= s.er.x1; ++cx) {
            LocalCell& cell = s.at(cx, cy);
            const DetailPatch* old = cell.old;
            if (old == nullptr && !cell.has)
                continue;
            if (old != nullptr && cell.has && old->control == cell.patch.control)
                continue;
            PatchChange change{tileOfCell(cx, cy), localCell(cx, cy), !cell.has, {}};
            if (cell.has) {
                (old == nullptr ? s.effect.patches_created : s.effect.patches_changed) += 1;
                change.patch = cell.patch;
                bounded.push_back({changes.size(), cx, cy});
            } else {
                ++s.effect.patches_removed;
            }
            changes.push_back(change);
            s.effect.dirty_tiles.push_back(change.tile);
            // border enforcement reaches one ring past the footprint's cells
            s.effect.cells = {
                std::min(s.effect.cells.x0, cx), std::min(s.effect.cells.y0, cy),
                std::max(s.effect.cells.x1, cx), std::max(s.effect.cells.y1, cy)};
        }
    forEachTask(runner, bounded.size(), 16, [&](std::size_t i) {
        const Bounded& b = bounded[i];
        updateBounds(changes[b.change].patch, corners(b.cx, b.cy));
    });
    std::sort(changes.begin(), changes.end(), [](const PatchChange& a, const PatchChange& b) {
        return a.tile != b.tile ? a.tile < b.tile : a.cell < b.cell;
    });
    applyPatchChanges(changes, runner);
    std::sort(s.effect.dirty_tiles.begin(), s.effect.dirty_tiles.end());
    s.effect.dirty_tiles.erase(
        std::unique(s.effect.dirty_tiles.begin(), s.effect.dirty_tiles.end()),
        s.effect.dirty_tiles.end());
    forEachTask(runner, s.effect.dirty_tiles.size(), 2, [&](std::size_t i) {
        rehashTile(s.effect.dirty_tiles[i]);
    });
    if (!s.effect.dirty_tiles.empty())
        rehashWorld();
}

} // namespace terrain
