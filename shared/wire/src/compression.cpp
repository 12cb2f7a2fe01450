#include <terrain/assert.h>
#include <terrain/wire/compression.h>

#include <zstd.h>

#include <algorithm>
#include <memory>
#include <string>

namespace terrain::wire {

std::vector<std::uint8_t> compress(std::span<const std::uint8_t> raw, int level) {
    // the bound is as large as the input: left uninitialised, only the pages zstd writes are
    // ever resident, and the result is copied out at its size (a server builds snapshots of
    // tens of MB and keeps the compressed ones)
    const std::size_t bound = ZSTD_compressBound(raw.size());
    const std::unique_ptr<std::uint8_t[]> out(new std::uint8_t[bound]);
    const std::size_t n = ZSTD_compress(out.get(), bound, raw.data(), raw.size(), level);
    TERRAIN_ASSERT(!ZSTD_isError(n)); // only fails on a too-small output, which Bound prevents
    return std::vector<std::uint8_t>(out.get(), out.get() + n);
}

Result<std::vector<std::uint8_t>> decompress(
    std::span<const std::uint8_t> compressed,
    std::size_t expected_raw_bytes,
    std::size_t max_raw_bytes) {
    if (expected_raw_bytes > max_raw_bytes)
        return makeError(
            ErrorCode::kOutOfRange, "declared size of " + std::to_string(expected_raw_bytes) +
                                        " bytes is above the limit of " +
                                        std::to_string(max_raw_bytes));
    const unsigned long long content =
        ZSTD_getFrameContentSize(compressed.data(), compressed.size());
    if (content == ZSTD_CONTENTSIZE_ERROR || content == ZSTD_CONTENTSIZE_UNKNOWN)
        return makeError(ErrorCode::kBadFormat, "not a zstd frame with a declared content size");
    if (content != expected_raw_bytes)
        return makeError(
            ErrorCode::kSizeMismatch, "zstd content size " + std::to_string(content) +
                                          " differs from the declared " +
                                          std::to_string(expected_raw_bytes) + " bytes");
    std::vector<std::uint8_t> out(expected_raw_bytes);
    const std::size_t n =
        ZSTD_decompress(out.data(), out.size(), compressed.data(), compressed.size());
    if (ZSTD_isError(n))
        return makeError(ErrorCode::kBadFormat, std::string("zstd: ") + ZSTD_getErrorName(n));
    if (n != expected_raw_bytes)
        return makeError(ErrorCode::kSizeMismatch, "zstd frame decompressed to the wrong size");
    return out;
}

Result<RawBytes>
decompressFrame(std::span<const std::uint8_t> compressed, std::size_t max_raw_bytes) {
    const unsigned long long content =
        ZSTD_getFrameContentSize(compressed.data(), compressed.size());
    if (content == ZSTD_CONTENTSIZE_ERROR || content == ZSTD_CONTENTSIZE_UNKNOWN)
        return makeError(ErrorCode::kBadFormat, "not a zstd frame with a declared content size");
    if (content > max_raw_bytes)
        return makeError(
            ErrorCode::kOutOfRange, "declared size of " + std::to_string(content) +
                                        " bytes is above the limit of " +
                                        std::to_string(max_raw_bytes));
    RawBytes out;
    out.size = static_cast<std::size_t>(content);
    out.data.reset(new std::uint8_t[std::max<std::size_t>(out.size, 1)]);
    const std::size_t n =
        ZSTD_decompress(out.data.get(), out.size, compressed.data(), compressed.size());
    if (ZSTD_isError(n))
        return makeError(ErrorCode::kBadFormat, std::string("zstd: ") + ZSTD_getErrorName(n));
    if (n != out.size)
        return makeError(ErrorCode::kSizeMismatch, "zstd frame decompressed to the wrong size");
    return out;
}

bool isZstdFrame(std::span<const std::uint8_t> bytes) {
    return bytes.size() >= 4 && bytes[0] == 0x28 && bytes[1] == 0xB5 && bytes[2] == 0x2F &&
           bytes[3] == 0xFD;
}

} // namespace terrain::wire
