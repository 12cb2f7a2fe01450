#pragma once

// A desync report, after Factorio's and Recoil's: when a replay diverges, everything needed to
// see where and how, written to a folder, with no debugger and no rerun:
//   report.json      seq, op, who diverged, both hashes, and each differing tile (its cells,
//                    both tile hashes, samples and patches that differ, the largest height
//                    difference in metres)
//   report.txt       the same for people, with the legend of the picture
//   tile-<t>-expected.txt, tile-<t>-observed.txt
//                    each differing tile's whole state (65 x 65 samples and original ground in
//                    quanta, every detail patch's 25 controls), in the same layout: `diff -u`
//                    shows the change
//   difference.png   the differing tiles' area, one pixel per vertex (scaled up when small):
//                    grey relief where equal, red where the observed ground is higher, blue
//                    where lower (brightness: the difference over the largest one), yellow
//                    where only a detail patch differs
// "expected" is the journal's state at the seq (stateAt()), "observed" the diverged one.

#include <terrain/deform_op.h>
#include <terrain/result.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace terrain::replay {

struct DesyncFacts {
    std::uint64_t seq = 0;
    DeformOp op;
    std::string who;   ///< "client-2 (differs from the server it follows)", ...
    std::string where; ///< the journal it came from
    std::uint64_t expected_hash = 0;
    std::uint64_t observed_hash = 0;
};

struct TileDifference {
    std::int32_t tile = 0;
    std::uint64_t expected_hash = 0;
    std::uint64_t observed_hash = 0;
    std::size_t samples_differing = 0;
    std::size_t patches_differing = 0; ///< cells whose patch differs, appears or disappears
    double max_difference_metres = 0.0;
};

/// Tiles whose hashes differ between two states of one world, ascending.
std::vector<TileDifference> differingTiles(const Terrain& expected, const Terrain& observed);

/// Writes the report into `dir` (created; files in it replaced). Errors: kIo naming the file;
/// kSizeMismatch when the two states are not of one world.
Status writeDesyncReport(
    const std::filesystem::path& dir,
    const DesyncFacts& facts,
    const Terrain& expected,
    const Terrain& observed);

} // namespace terrain::replay
