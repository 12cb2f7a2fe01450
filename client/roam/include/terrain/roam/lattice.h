#pragma once

// The geometry of the 4-8 mesh that every tile's two bintrees refine, in integer lattice units.
//
// One lattice unit is 1/16 of a cell, the spacing of a detail patch's 17 x 17 grid, so every
// vertex the tessellator can create (base grid, cell centres, patch grid points) has integer
// coordinates; a tile is 1024 units. A triangle at level L is a right isosceles triangle: level
// 0 are the two halves of a tile, level 12 the two halves of a cell (the base surface's own
// triangles, diagonal by (x + y) parity as in base_cell.h), level 20 the finest patch triangles.
//
// Refinement is expressed with diamonds (Duchaineau et al., ROAM; Lindstrom & Pascucci): every
// vertex except a tile corner is the centre of exactly one diamond, the pair of level-L
// triangles sharing the hypotenuse it bisects. Splitting a diamond adds its centre; it is
// allowed only when its parents (the apexes of its two triangles) are split. That one rule is
// what makes the mesh crack-free, within a tile and across tile borders alike, with no
// neighbour pointers: a diamond's parents and children are found from its coordinates.
// Pure, header only.

#include <terrain/world_spec.h>

#include <array>
#include <bit>
#include <cstdint>

namespace terrain::roam {

inline constexpr std::int32_t kLatticePerCell = 16;
inline constexpr std::int32_t kLatticePerTile = kLatticePerCell * kTileCells;
inline constexpr int kTileTriangleLevel = 0;
inline constexpr int kCellTriangleLevel = 12;   ///< the base cells' own half-cell triangles
inline constexpr int kFinestTriangleLevel = 20; ///< legs of 1/16 cell: the patch grid
inline constexpr int kMaxDiamondLevel = kFinestTriangleLevel - 1;

struct LatticePoint {
    std::int32_t x = 0;
    std::int32_t y = 0;
    friend constexpr bool operator==(LatticePoint, LatticePoint) = default;
};

constexpr LatticePoint operator+(LatticePoint a, LatticePoint b) {
    return {a.x + b.x, a.y + b.y};
}

constexpr LatticePoint midpoint(LatticePoint a, LatticePoint b) {
    return {(a.x + b.x) / 2, (a.y + b.y) / 2};
}

constexpr bool isGridVertex(LatticePoint p) {
    return p.x % kLatticePerCell == 0 && p.y % kLatticePerCell == 0;
}

constexpr int trailingZeros(std::int32_t v) {
    return v == 0 ? 31 : std::countr_zero(static_cast<std::uint32_t>(v));
}

/// A diamond: its centre, level (0..19) and half size in lattice units. Even levels are axis-
/// aligned squares (half side = half); odd levels are squares turned 45 degrees whose
/// hypotenuse, of length 2 * half, is axis-aligned.
struct Diamond {
    LatticePoint centre;
    int level = -1; ///< -1: a tile corner, which is a root vertex and no diamond
    std::int32_t half = 0;
    /// Even levels: the square's diagonal runs from (-h,-h) to (h,h). Odd levels: the hypotenuse
    /// runs along x.
    bool main_or_horizontal = false;

    bool valid() const { return level >= 0; }
};

constexpr Diamond diamondAt(LatticePoint p) {
    if (p.x % kLatticePerTile == 0 && p.y % kLatticePerTile == 0)
        return {};
    const int tx = trailingZeros(p.x);
    const int ty = trailingZeros(p.y);
    const int t = tx < ty ? tx : ty;
    Diamond d;
    d.centre = p;
    d.half = 1 << t;
    if (tx == ty) {
        d.level = 18 - 2 * t;
        // the checkerboard of square diagonals at this level, as base_cell.h has it at level 12
        const std::int32_t i = (p.x - d.half) / (2 * d.half);
        const std::int32_t j = (p.y - d.half) / (2 * d.half);
        d.main_or_horizontal = ((i + j) & 1) == 0;
    } else {
        d.level = 19 - 2 * t;
        d.main_or_horizontal = tx == t;
    }
    return d;
}

/// The two apexes of the diamond's triangles. For levels >= 1 these are its parents.
constexpr std::array<LatticePoint, 2> apexes(const Diamond& d) {
    const LatticePoint c = d.centre;
    const std::int32_t h = d.half;
    if (d.level % 2 == 0) {
        if (d.main_or_horizontal)
            return {{{c.x + h, c.y - h}, {c.x - h, c.y + h}}};
        return {{{c.x - h, c.y - h}, {c.x + h, c.y + h}}};
    }
    if (d.main_or_horizontal)
        return {{{c.x, c.y - h}, {c.x, c.y + h}}};
    return {{{c.x - h, c.y}, {c.x + h, c.y}}};
}

/// The ends of the shared hypotenuse, whose midpoint is the centre.
constexpr std::array<LatticePoint, 2> hypotenuseEnds(const Diamond& d) {
    const LatticePoint c = d.centre;
    const std::int32_t h = d.half;
    if (d.level % 2 == 0) {
        if (d.main_or_horizontal)
            return {{{c.x - h, c.y - h}, {c.x + h, c.y + h}}};
        return {{{c.x + h, c.y - h}, {c.x - h, c.y + h}}};
    }
    if (d.main_or_horizontal)
        return {{{c.x - h, c.y}, {c.x + h, c.y}}};
    return {{{c.x, c.y - h}, {c.x, c.y + h}}};
}

/// The centres of the (up to) four diamonds one level finer whose triangles split this one's.
/// Level-19 diamonds have none: their children are the finest triangles.
constexpr int children(const Diamond& d, std::array<LatticePoint, 4>& out) {
    const LatticePoint c = d.centre;
    const std::int32_t h = d.half;
    if (d.level >= kMaxDiamondLevel)
        return 0;
    if (d.level % 2 == 0) {
        out = {{{c.x - h, c.y}, {c.x + h, c.y}, {c.x, c.y - h}, {c.x, c.y + h}}};
    } else {
        const std::int32_t q = h / 2;
        out = {{{c.x - q, c.y - q}, {c.x + q, c.y - q}, {c.x - q, c.y + q}, {c.x + q, c.y + q}}};
    }
    return 4;
}

/// Half width of the square, centred on the diamond, that holds it and all its descendants
/// (children of a diamond reach beyond it, into its neighbours' triangles).
constexpr std::int32_t subtreeReach(const Diamond& d) {
    return d.level % 2 == 0 ? 3 * d.half : 2 * d.half;
}

/// A triangle: apex (right angle) and hypotenuse ends, counter-clockwise in (x, y).
struct Triangle {
    LatticePoint apex;
    LatticePoint left;
    LatticePoint right;
    int level = 0;
};

constexpr std::int64_t cross(LatticePoint o, LatticePoint a, LatticePoint b) {
    return static_cast<std::int64_t>(a.x - o.x) * (b.y - o.y) -
           static_cast<std::int64_t>(a.y - o.y) * (b.x - o.x);
}

/// The diamond's triangle with apex `apex`, oriented counter-clockwise.
constexpr Triangle triangleOf(const Diamond& d, LatticePoint apex) {
    const auto ends = hypotenuseEnds(d);
    if (cross(apex, ends[0], ends[1]) > 0)
        return {apex, ends[0], ends[1], d.level};
    return {apex, ends[1], ends[0], d.level};
}

/// The two halves of t, split at its hypotenuse midpoint; both keep the orientation.
constexpr std::array<Triangle, 2> splitTriangle(const Triangle& t) {
    const LatticePoint m = midpoint(t.left, t.right);
    return {{{m, t.apex, t.left, t.level + 1}, {m, t.right, t.apex, t.level + 1}}};
}

/// Centre of the diamond whose split would split t.
constexpr LatticePoint splitPoint(const Triangle& t) {
    return midpoint(t.left, t.right);
}

/// A key naming a triangle uniquely within its tile (whose lattice origin is `origin`): the
/// doubled hypotenuse midpoint relative to the origin (0..2048 on each axis, 12 bits) and the
/// apex's direction (4 bits), in 28 bits. Tile meshes keep their keys in half the memory.
constexpr std::uint32_t tileTriangleKey(const Triangle& t, LatticePoint origin) {
    const std::int32_t mx2 = t.left.x + t.right.x;
    const std::int32_t my2 = t.left.y + t.right.y;
    const std::int32_t dx = 2 * t.apex.x - mx2;
    const std::int32_t dy = 2 * t.apex.y - my2;
    const std::uint32_t dir = static_cast<std::uint32_t>((dx > 0) - (dx < 0) + 1) * 3 +
                              static_cast<std::uint32_t>((dy > 0) - (dy < 0) + 1);
    return (static_cast<std::uint32_t>(mx2 - 2 * origin.x) << 16) |
           (static_cast<std::uint32_t>(my2 - 2 * origin.y) << 4) | dir;
}

/// Three times the centroid, to find a triangle's tile or cell without fractions.
constexpr LatticePoint centroidTimes3(const Triangle& t) {
    return {t.apex.x + t.left.x + t.right.x, t.apex.y + t.left.y + t.right.y};
}

} // namespace terrain::roam
