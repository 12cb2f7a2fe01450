#pragma once

// LEB128 numbers as the genesis delta and OpBatch write them (PROTOCOL.md): 7 bits a byte, low
// first, the high bit set on every byte but the last, always in the shortest form, so that every
// value has one encoding; zigzag maps signed values to unsigned (0, -1, 1, -2 -> 0, 1, 2, 3).

#include <cstddef>
#include <cstdint>
#include <span>

namespace terrain::varint {

/// Appends v to `out` (a byte container: std::vector<std::uint8_t>, std::string).
template <typename Bytes> void put(Bytes& out, std::uint64_t v) {
    using Byte = typename Bytes::value_type;
    while (v >= 0x80) {
        out.push_back(static_cast<Byte>(v | 0x80));
        v >>= 7;
    }
    out.push_back(static_cast<Byte>(v));
}

constexpr std::uint32_t zigzag(std::int32_t v) {
    return (static_cast<std::uint32_t>(v) << 1) ^ static_cast<std::uint32_t>(v >> 31);
}

constexpr std::int32_t unzigzag(std::uint32_t z) {
    return static_cast<std::int32_t>((z >> 1) ^ (~(z & 1) + 1));
}

template <typename Bytes> void putSigned(Bytes& out, std::int32_t v) {
    put(out, zigzag(v));
}

/// Reads one number at `at` (advanced past it): at most 10 bytes, 64 bits, shortest form.
/// False on truncation, overflow or a longer form than needed (`at` is then unspecified).
inline bool read(std::span<const std::uint8_t> bytes, std::size_t& at, std::uint64_t& v) {
    v = 0;
    for (int shift = 0; shift < 70; shift += 7) {
        if (at >= bytes.size())
            return false;
        const std::uint8_t b = bytes[at++];
        if (shift == 63 && (b & 0x7e) != 0)
            return false; // beyond 64 bits
        v |= static_cast<std::uint64_t>(b & 0x7f) << shift;
        if ((b & 0x80) == 0)
            return b != 0 || shift == 0; // a zero last byte: a longer form than needed
    }
    return false;
}

/// A number that must fit 32 bits (so at most 5 bytes in its shortest form).
inline bool read32(std::span<const std::uint8_t> bytes, std::size_t& at, std::uint32_t& v) {
    std::uint64_t wide = 0;
    if (!read(bytes, at, wide) || wide > 0xffffffffu)
        return false;
    v = static_cast<std::uint32_t>(wide);
    return true;
}

inline bool readSigned(std::span<const std::uint8_t> bytes, std::size_t& at, std::int32_t& v) {
    std::uint32_t z = 0;
    if (!read32(bytes, at, z))
        return false;
    v = unzigzag(z);
    return true;
}

} // namespace terrain::varint
