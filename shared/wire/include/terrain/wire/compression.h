#pragma once

// zstd for bulk state (snapshots, repair tiles). Decompression trusts nothing: the declared
// content size must match what the sender announced and stay below the caller's limit.

#include <terrain/result.h>

#include <cstddef>
#include <cstdint>
#include <memory>
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

/// Bytes decompressed into a buffer that is never initialised: a frame that declares more than
/// it holds costs only the pages it fills.
struct RawBytes {
    std::unique_ptr<std::uint8_t[]> data;
    std::size_t size = 0;
    std::span<const std::uint8_t> bytes() const { return {data.get(), size}; }
};

/// Decompresses a frame whose size nobody announced: its own declared content size, which must
/// be at most max_raw_bytes. Errors: kBadFormat (not one zstd frame with a declared content
/// size, or corrupt), kOutOfRange (above the limit), kSizeMismatch (another size than declared).
Result<RawBytes>
decompressFrame(std::span<const std::uint8_t> compressed, std::size_t max_raw_bytes);

/// True when the bytes begin with zstd's frame magic (28 B5 2F FD).
bool isZstdFrame(std::span<const std::uint8_t> bytes);

} // namespace terrain::wire
