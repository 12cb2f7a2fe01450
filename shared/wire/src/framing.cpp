#include <terrain/wire/framing.h>

#include <algorithm>
#include <cstring>
#include <string>

namespace terrain::wire {

void appendFramePrefix(std::size_t size, std::vector<std::uint8_t>& out) {
    std::uint64_t v = size;
    while (v >= 0x80) {
        out.push_back(static_cast<std::uint8_t>((v & 0x7f) | 0x80));
        v >>= 7;
    }
    out.push_back(static_cast<std::uint8_t>(v));
}

std::size_t framePrefixSize(std::size_t size) {
    std::size_t n = 1;
    for (std::uint64_t v = size; v >= 0x80; v >>= 7)
        ++n;
    return n;
}

FrameReader::FrameReader(std::size_t max_frame_bytes)
    : max_frame_bytes_(std::min(max_frame_bytes, kMaxFrameBytesLimit)) {}

void FrameReader::compact() {
    if (begin_ == 0)
        return;
    std::memmove(buffer_.data(), buffer_.data() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
}

std::span<std::uint8_t> FrameReader::prepare(std::size_t min_bytes) {
    if (buffer_.size() - end_ < min_bytes) {
        compact();
        if (buffer_.size() - end_ < min_bytes)
            buffer_.resize(end_ + min_bytes);
    }
    return {buffer_.data() + end_, buffer_.size() - end_};
}

void FrameReader::commit(std::size_t n) {
    end_ += std::min(n, buffer_.size() - end_);
}

void FrameReader::feed(std::span<const std::uint8_t> bytes) {
    std::span<std::uint8_t> space = prepare(bytes.size());
    std::memcpy(space.data(), bytes.data(), bytes.size());
    commit(bytes.size());
}

Result<std::optional<std::span<const std::uint8_t>>> FrameReader::next() {
    std::uint64_t length = 0;
    std::size_t prefix = 0;
    for (;;) {
        if (begin_ + prefix == end_)
            return std::optional<std::span<const std::uint8_t>>{}; // prefix incomplete
        const std::uint8_t byte = buffer_[begin_ + prefix];
        length |= std::uint64_t{byte & 0x7fu} << (7 * prefix);
        ++prefix;
        // note: the limit is checked on every prefix byte, before any body byte is kept
        if (length > max_frame_bytes_)
            return makeError(
                ErrorCode::kOutOfRange, "frame of " + std::to_string(length) +
                                            "+ bytes is above the limit of " +
                                            std::to_string(max_frame_bytes_) + " bytes");
        if ((byte & 0x80u) == 0)
            break;
        if (prefix == kMaxPrefixBytes)
            return makeError(ErrorCode::kBadFormat, "frame length prefix is longer than 5 bytes");
    }
    if (length == 0)
        return makeError(ErrorCode::kBadFormat, "frame of zero bytes (an envelope is never empty)");
    const std::size_t size = static_cast<std::size_t>(length);
    if (end_ - begin_ - prefix < size) {
        // reserve the whole frame once its length is known and accepted
        if (buffer_.size() - begin_ < prefix + size) {
            compact();
            if (buffer_.size() < prefix + size)
                buffer_.resize(prefix + size);
        }
        return std::optional<std::span<const std::uint8_t>>{};
    }
    const std::span<const std::uint8_t> body(buffer_.data() + begin_ + prefix, size);
    begin_ += prefix + size;
    if (begin_ == end_)
        begin_ = end_ = 0;
    return std::optional<std::span<const std::uint8_t>>{body};
}

} // namespace terrain::wire
