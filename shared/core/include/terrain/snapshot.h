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
#include <functional>
#include <span>
#include <vector>

namespace terrain {

/// 2 since the v2 crater model: tile records carry the original ground, and a world that v1 ops
/// built cannot be continued by v2 ops, so v1 snapshots are refused by name.
inline constexpr std::uint32_t kSnapshotVersion = 2;

std::vector<std::uint8_t> encodeSnapshot(const Terrain& terrain, std::uint64_t sequence);

/// The size of encodeSnapshot()'s bytes, without encoding them.
std::uint64_t snapshotBytes(const Terrain& terrain);

/// Receives a snapshot's bytes in order, a piece at a time.
using SnapshotSink = std::function<void(std::span<const std::uint8_t>)>;

/// encodeSnapshot()'s bytes handed to `sink` in pieces of about `piece_bytes`, so that the whole
/// is never held (a server compresses them as they come: the raw snapshot of a default map is
/// 35 MB, its compressed form a few). snapshotBytes() gives the total beforehand.
void encodeSnapshotTo(
    const Terrain& terrain,
    std::uint64_t sequence,
    const SnapshotSink& sink,
    std::size_t piece_bytes = std::size_t{1} << 20);

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
