#pragma once

// The three grains of a detail block: a cell refined below the base grid rarely needs all of its
// 17 x 17 vertices and 255 finer diamonds. In a battle most refined cells stop at a quarter of a
// cell, a few go to an eighth, and only the cells next to the eye reach the patch's own grid. So
// a block is stored in up to three chunks, each materialised only when a split needs it:
//
//   grain | lattice points (local k, l)    | diamond levels | diamonds | vertices
//   ------+--------------------------------+----------------+----------+---------
//     0   | both multiples of 4 (5 x 5)    | 13 - 15        | 16 (*)   | 25
//     1   | both even, not both of 4       | 16 - 17        | 48       | 56
//     2   | at least one odd               | 18 - 19        | 192      | 208
//
// (*) 16 slots for the 4 x 4 half-open positions, of which the grid vertex (0, 0) and the cell's
// centre (8, 8) (an eager diamond) are unused. Diamonds are the cell's half-open 16 x 16 lattice
// (border diamonds belong to the cell on their +x / +y side); vertices are its closed 17 x 17
// square (a border vertex is in both cells' chunks, with the same height). Every triangle of a
// level finer than the base cells lies in one cell and has its vertices in that cell's grain of
// its level or coarser, and the diamond that made it is in that grain too, so a chunk with no
// split diamond and no candidate holds no vertex any triangle uses. Pure, header only (tables
// built once).

#include <terrain/roam/lattice.h>

#include <array>
#include <cstdint>

namespace terrain::roam {

inline constexpr int kGrains = 3;
inline constexpr std::array<std::int32_t, kGrains> kGrainDiamonds = {16, 48, 192};
inline constexpr std::array<std::int32_t, kGrains> kGrainVertices = {25, 56, 208};
/// The finest diamond level of each grain: a split there makes the next grain's diamonds
/// candidates, so it needs that grain.
inline constexpr std::array<int, kGrains> kGrainDeepestLevel = {15, 17, 19};

/// Grain of local lattice position (k, l), both in [0, 16].
constexpr int grainOf(std::int32_t k, std::int32_t l) {
    if ((k | l) % 4 == 0)
        return 0;
    return (k | l) % 2 == 0 ? 1 : 2;
}

struct GrainTables {
    /// Slot of a diamond within its grain, by local position l * 16 + k.
    std::array<std::uint8_t, kLatticePerCell * kLatticePerCell> diamond_slot{};
    /// Local position (l * 16 + k) of each slot of each grain.
    std::array<std::array<std::uint8_t, 192>, kGrains> diamond_local{};
    /// Slot of a vertex within its grain, by local position l * 17 + k.
    std::array<std::uint8_t, 17 * 17> vertex_slot{};
    /// Local position (l * 17 + k) of each vertex slot of each grain.
    std::array<std::array<std::uint16_t, 208>, kGrains> vertex_local{};
};

inline const GrainTables& grainTables() {
    static const GrainTables tables = [] {
        GrainTables t;
        std::array<int, kGrains> diamonds{};
        std::array<int, kGrains> vertices{};
        for (std::int32_t l = 0; l < kLatticePerCell; ++l)
            for (std::int32_t k = 0; k < kLatticePerCell; ++k) {
                const int g = grainOf(k, l);
                const auto local = static_cast<std::size_t>(l * kLatticePerCell + k);
                // grain 0 keeps the 4 x 4 layout, unused slots included, so slot = (l/4)*4 + k/4
                const int slot =
                    g == 0 ? (l / 4) * 4 + k / 4 : diamonds[static_cast<std::size_t>(g)]++;
                t.diamond_slot[local] = static_cast<std::uint8_t>(slot);
                t.diamond_local[static_cast<std::size_t>(g)][static_cast<std::size_t>(slot)] =
                    static_cast<std::uint8_t>(local);
            }
        for (std::int32_t l = 0; l <= kLatticePerCell; ++l)
            for (std::int32_t k = 0; k <= kLatticePerCell; ++k) {
                const int g = grainOf(k, l);
                const auto local = static_cast<std::size_t>(l * (kLatticePerCell + 1) + k);
                const int slot = vertices[static_cast<std::size_t>(g)]++;
                t.vertex_slot[local] = static_cast<std::uint8_t>(slot);
                t.vertex_local[static_cast<std::size_t>(g)][static_cast<std::size_t>(slot)] =
                    static_cast<std::uint16_t>(local);
            }
        return t;
    }();
    return tables;
}

} // namespace terrain::roam
