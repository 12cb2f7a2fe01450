#pragma once

// A world as the difference from its genesis, for clients that already hold the genesis (the
// procedural map of a seed, or the DEM the game ships). The genesis is the original ground with
// no op on it: every Terrain carries it (Terrain::original), so a client that ever held any state
// of a world, or generated its genesis itself, can take a delta instead of a whole snapshot.
// Only the tiles that differ from the genesis are sent, and their bytes are coded to be small:
// displacements from the original ground (zero outside the craters), and patch controls as the
// residual from a prediction, with every control the receiver can infer left out.
//
// Layout, little-endian; var = LEB128, zig = zigzag then LEB128 (PROTOCOL.md has the full text):
//   "TRGD" u32 version (kGenesisDeltaVersion)
//   i32 width, height, spacing, units_per_metre, patch_tolerance
//   u64 sequence, u64 genesis hash (Terrain::genesisHash of the base)
//   u32 tile count, then per tile in ascending tile order:
//     var (tile - previous tile - 1; the first: tile), var record length, record:
//       65 x 65 zig displacements (sample - original ground), row-major
//       var patch count, then per patch var (cell - previous cell - 1; the first: cell)
//       then per patch, per control j = 0..4, i = 0..4 that is sent: zig (control - predicted)
//   u64 world hash, u64 checksum (XXH3-64 of every byte before it)
// A control is not sent when the receiver knows it: the four corners (pinned to the base
// corners), a border facing an unpatched cell inside the map (straight), row j = 0 facing a
// patch below and column i = 0 facing a patch to the left (equal to that patch's facing row,
// decoded first). The prediction (genesis_delta.cpp, predictControls) is the cubic interpolant
// at the Greville points of the Catmull-Rom surface through the 4 x 4 samples around the cell.
// Decoding treats every byte as untrusted: it never asserts, and every refusal names the rule.

#include <terrain/result.h>
#include <terrain/snapshot.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <span>
#include <vector>

namespace terrain {

inline constexpr std::uint32_t kGenesisDeltaVersion = 1;

/// `genesis_hash` is terrain.genesisHash() (callers compute it once: it hashes the whole map).
std::vector<std::uint8_t>
encodeGenesisDelta(const Terrain& terrain, std::uint64_t sequence, std::uint64_t genesis_hash);

/// The world the delta describes, built on the genesis of `holder` (its original ground; its
/// samples and patches are not used). Errors: kTruncated, kBadFormat (magic, order, trailing
/// bytes, overlong numbers), kUnsupported (version), kSizeMismatch (another world's spec),
/// kHashMismatch (the holder's genesis differs, the checksum or the world hash differs),
/// kOutOfRange (tiles, cells, heights), kInvariantBroken (shared vertices or patch borders).
Result<DecodedSnapshot>
decodeGenesisDelta(std::span<const std::uint8_t> bytes, const Terrain& holder);

/// Largest delta a world of this spec can have (every tile differs, every cell patched, every
/// number at its longest): a receiver's bound on what a sender may announce.
std::uint64_t maxGenesisDeltaBytes(const WorldSpec& spec);

} // namespace terrain
