#pragma once

// Stream framing: every frame is a base-128 varint length prefix (at most 5 bytes, little-endian
// groups of 7 bits, as protobuf writes it) followed by that many bytes of one Envelope.
// The length is checked against the session's limit before a byte of the body is buffered.
// Pure: no sockets; the caller moves bytes in (prepare/commit) and frames out (next).

#include <terrain/result.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace terrain::wire {

inline constexpr std::size_t kDefaultMaxFrameBytes = std::size_t{1} << 20;
/// Highest limit a session may configure (the prefix never exceeds 4 bytes then).
inline constexpr std::size_t kMaxFrameBytesLimit = std::size_t{64} << 20;
inline constexpr std::size_t kMaxPrefixBytes = 5;

/// Appends the length prefix of a frame of `size` bytes.
void appendFramePrefix(std::size_t size, std::vector<std::uint8_t>& out);

/// Number of bytes appendFramePrefix writes for `size`.
std::size_t framePrefixSize(std::size_t size);

/// Reassembles frames from a byte stream. Memory stays below max_frame_bytes + a read buffer.
class FrameReader {
  public:
    explicit FrameReader(std::size_t max_frame_bytes = kDefaultMaxFrameBytes);

    /// Writable space of at least `min_bytes` for the next socket read.
    std::span<std::uint8_t> prepare(std::size_t min_bytes);
    /// Marks `n` bytes of the last prepare() as received.
    void commit(std::size_t n);
    /// Appends bytes (tests and fuzzing; same as prepare + copy + commit).
    void feed(std::span<const std::uint8_t> bytes);

    /// The next complete frame body, valid until the next call on this reader; nullopt when more
    /// bytes are needed. Errors (the stream cannot continue; close the session):
    /// kBadFormat for a prefix longer than 5 bytes or a zero-length frame, kOutOfRange for a
    /// length above the limit.
    Result<std::optional<std::span<const std::uint8_t>>> next();

    std::size_t buffered() const { return end_ - begin_; }
    std::size_t maxFrameBytes() const { return max_frame_bytes_; }

  private:
    void compact();

    std::size_t max_frame_bytes_;
    std::vector<std::uint8_t> buffer_;
    std::size_t begin_ = 0; // first unconsumed byte
    std::size_t end_ = 0;   // one past the last received byte
};

} // namespace terrain::wire
