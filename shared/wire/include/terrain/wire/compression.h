#pragma once

// zstd for bulk state (snapshots, repair tiles). Decompression trusts nothing: the declared
// content size must match what the sender announced and stay below the caller's limit.

#include <terrain/result.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace terrain::wire {

/// zstd level 1: snapshots are built on the server's thread, so speed beats ratio here.
inline constexpr int kDefaultCompressionLevel = 1;

std::vector<std::uint8_t>
compress(std::span<const std::uint8_t> raw, int level = kDefaultCompressionLevel);

/// Errors: kBadFormat (not one zstd frame, or corrupt), kSizeMismatch (content size differs from
/// expected_raw_bytes), kOutOfRange (expected_raw_bytes above max_raw_bytes).
Result<std::vector<std::uint8_t>> decompress(
    std::span<const std::uint8_t> compressed,
    std::size_t expected_raw_bytes,
    std::size_t max_raw_bytes);

} // namespace terrain::wire
