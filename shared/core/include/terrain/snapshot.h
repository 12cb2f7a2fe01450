#pragma once

// Whole-state snapshots (join, persistence) and single-tile records (snapshot chunks, repair).
//
// Snapshot layout, little-endian:
//   "TRSN" u32 version (kSnapshotVersion)
//   i32 width, height, spacing, units_per_metre, patch_tolerance
//   u64 sequence            (opaque to the core; the server's op sequence number)
//   u32 tile_count, then per tile: u32 byte length + Terrain::appendTileBytes() record
//   u64 world hash          (checked on decode against the decoded state)
//   u64 checksum            XXH3-64 of every byte before it (covers header and sequence)
// Decoding treats every byte as untrusted: it never asserts, and every refusal names the rule.

#include <terrain/result.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <span>
#include <vector>

namespace terrain {

/// 2 since the v2 crater model: tile records carry the original ground, and a world that v1 ops
/// built cannot be continued by v2 ops, so v1 snapshots are refused by name.
inline constexpr std::uint32_t kSnapshotVersion = 2;

std::vector<std::uint8_t> encodeSnapshot(const Terrain& terrain, std::uint64_t sequence);

struct DecodedSnapshot {
    Terrain terrain;
    std::uint64_t sequence = 0;
};

/// Errors: kTruncated, kBadFormat (magic, trailing bytes, tile order), kUnsupported (version),
/// the spec's own rules, kOutOfRange (samples, controls, cells), kInvariantBroken (patch
/// corners or borders), kHashMismatch (world hash differs from the recomputed one, or the
/// checksum differs).
Result<DecodedSnapshot> decodeSnapshot(std::span<const std::uint8_t> bytes);

/// One tile's decoded record.
struct TileRecord {
    std::int32_t tile = 0;
    std::vector<std::int32_t> samples;   ///< 65 x 65, row-major
    std::vector<std::int32_t> originals; ///< 65 x 65: the original ground (sample - displacement)
    std::vector<PatchEntry> patches;     ///< ascending cell order
};

/// Decodes one Terrain::appendTileBytes() record for a world of `spec`.
Result<TileRecord> decodeTile(std::span<const std::uint8_t> bytes, const WorldSpec& spec);

} // namespace terrain
