#pragma once

// Little-endian encoding helpers private to the core (hash input, snapshots).

#include <terrain/varint.h>

#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

namespace terrain::detail {

inline void putU16(std::vector<std::uint8_t>& out, std::uint16_t v) {
    out.push_back(static_cast<std::uint8_t>(v));
    out.push_back(static_cast<std::uint8_t>(v >> 8));
}

inline void putU32(std::vector<std::uint8_t>& out, std::uint32_t v) {
    for (int s = 0; s < 32; s += 8)
        out.push_back(static_cast<std::uint8_t>(v >> s));
}

inline void putI32(std::vector<std::uint8_t>& out, std::int32_t v) {
    putU32(out, static_cast<std::uint32_t>(v));
}

inline void putU64(std::vector<std::uint8_t>& out, std::uint64_t v) {
    for (int s = 0; s < 64; s += 8)
        out.push_back(static_cast<std::uint8_t>(v >> s));
}

inline void putVarU32(std::vector<std::uint8_t>& out, std::uint32_t v) {
    varint::put(out, v);
}

inline void putVarI32(std::vector<std::uint8_t>& out, std::int32_t v) {
    varint::putSigned(out, v);
}

/// Bounds-checked little-endian reader over untrusted bytes: every read reports failure
/// instead of reading past the end.
class ByteReader {
  public:
    explicit ByteReader(std::span<const std::uint8_t> bytes) : bytes_(bytes) {}

    std::size_t remaining() const { return bytes_.size() - pos_; }
    std::size_t position() const { return pos_; }

    bool u16(std::uint16_t& v) {
        std::uint64_t x = 0;
        if (!read(2, x))
            return false;
        v = static_cast<std::uint16_t>(x);
        return true;
    }
    bool u32(std::uint32_t& v) {
        std::uint64_t x = 0;
        if (!read(4, x))
            return false;
        v = static_cast<std::uint32_t>(x);
        return true;
    }
    bool i32(std::int32_t& v) {
        std::uint32_t x = 0;
        if (!u32(x))
            return false;
        v = static_cast<std::int32_t>(x);
        return true;
    }
    bool u64(std::uint64_t& v) { return read(8, v); }
    /// Reads n little-endian int32 values in one go.
    bool i32s(std::int32_t* out, std::size_t n) {
        if (remaining() / 4 < n)
            return false;
        if constexpr (std::endian::native == std::endian::little) {
            std::memcpy(out, bytes_.data() + pos_, n * 4);
            pos_ += n * 4;
            return true;
        }
        for (std::size_t i = 0; i < n; ++i)
            i32(out[i]);
        return true;
    }
    /// varint.h's numbers: false on truncation, overflow or a longer form than needed.
    bool varU32(std::uint32_t& v) { return varint::read32(bytes_, pos_, v); }
    bool varI32(std::int32_t& v) { return varint::readSigned(bytes_, pos_, v); }
    bool skip(std::size_t n) {
        if (remaining() < n)
            return false;
        pos_ += n;
        return true;
    }

  private:
    bool read(std::size_t n, std::uint64_t& v) {
        if (remaining() < n)
            return false;
        v = 0;
        for (std::size_t i = 0; i < n; ++i)
            v |= static_cast<std::uint64_t>(bytes_[pos_ + i]) << (8 * i);
        pos_ += n;
        return true;
    }

    std::span<const std::uint8_t> bytes_;
    std::size_t pos_ = 0;
};

} // namespace terrain::detail
