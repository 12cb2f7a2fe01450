#pragma once

// How bytes reach the GPU's buffers. During a frame, each change is staged (its bytes and where
// they go: a destination buffer and offset); flush() then writes the frame's bytes into a
// streaming ring buffer at once and copies them on the GPU (glCopyBufferSubData) into their
// destinations, in the order staged. Copies between buffers (one outgrown, into its successor)
// queue in the same order.
//
// Why: a destination buffer is only ever written by the GPU's own copies, in the GL's command
// order, so no write waits for a draw that still reads it and none lands out of order with
// another (the old path mixed glBufferSubData, glCopyBufferSubData and growth on buffers in
// use). The only buffer the CPU writes is the ring, and only into regions whose fence says the
// GPU has finished the copies that read them; a region still busy makes the ring grow rather
// than wait, up to kMaxBytes.
//
// Two ways into the ring: persistently mapped (GL 4.4 or ARB_buffer_storage: mapped once,
// coherent) or plain GL 3.3 (glMapBufferRange of the free region, unsynchronized, per flush).

#include <terrain/render/gl_api.h>
#include <terrain/result.h>

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

namespace terrain::render {

enum class UploadPath {
    kAuto,       ///< persistent where the context has it, else map-range
    kPersistent, ///< glBufferStorage + a persistent coherent mapping (GL 4.4)
    kMapRange,   ///< glMapBufferRange(UNSYNCHRONIZED | INVALIDATE_RANGE) per flush (GL 3.3)
};

const char* toString(UploadPath path);
/// "auto", "persistent" or "map-range"; errors: kOutOfRange naming the accepted names.
Result<UploadPath> parseUploadPath(const std::string& name);

/// What flush() did, summed since creation.
struct RingStats {
    std::uint64_t bytes = 0;       ///< written into the ring (the frame's uploads)
    std::uint64_t copies = 0;      ///< glCopyBufferSubData calls (ring and buffer-to-buffer)
    std::uint64_t copy_bytes = 0;  ///< moved GPU-to-GPU from outgrown buffers
    std::uint64_t flushes = 0;     ///< flushes that wrote anything
    std::uint64_t waits = 0;       ///< flushes that waited for a region (ring at kMaxBytes)
    std::uint64_t wait_ns = 0;     ///< time spent waiting
    std::uint64_t grown = 0;       ///< times the ring grew
    std::uint64_t map_retries = 0; ///< map-range: mappings lost (glUnmapBuffer false), resent
};

class UploadRing {
  public:
    static constexpr std::uint64_t kMinBytes = 1u << 20;
    static constexpr std::uint64_t kMaxBytes = 256u << 20;

    /// The context current. kPersistent falls back to kMapRange where the context lacks
    /// buffer storage (path() says which was taken).
    UploadRing(const GlApi& gl, UploadPath path, std::uint64_t bytes);
    ~UploadRing() = default;
    UploadRing(const UploadRing&) = delete;
    UploadRing& operator=(const UploadRing&) = delete;
    /// Gives the GL objects back (the context current): before the context goes.
    void release();

    UploadPath path() const { return path_; }
    std::uint64_t capacity() const { return size_; }

    /// Queues `bytes` from `data` (copied now) for `buffer` at byte `offset`.
    void stage(unsigned buffer, std::uint64_t offset, const void* data, std::uint64_t bytes);
    /// Queues a GPU copy of [0, bytes) of `from` into `to` at 0, in order with the staged bytes,
    /// and takes `from`: it is deleted once the copy is issued (a buffer outgrown).
    void moveBuffer(unsigned from, unsigned to, std::uint64_t bytes);
    /// Bytes staged since the last flush().
    std::uint64_t pendingBytes() const { return staged_.size(); }
    /// Writes what was staged into the ring and issues every queued copy. Leaves
    /// GL_COPY_READ_BUFFER and GL_COPY_WRITE_BUFFER bound to buffers of its own choosing.
    void flush();

    const RingStats& stats() const { return stats_; }

  private:
    struct Copy {
        unsigned from = 0; ///< 0: the ring, at the flush's region + `source`
        unsigned to = 0;
        std::uint64_t source = 0;
        std::uint64_t target = 0;
        std::uint64_t bytes = 0;
    };
    struct Region {
        std::uint64_t begin = 0;
        std::uint64_t end = 0;
        GLsync fence = nullptr;
    };

    void allocate(std::uint64_t bytes);
    /// Where `bytes` go in the ring: a region no unfinished copy reads (grows or waits).
    std::uint64_t reserve(std::uint64_t bytes);
    bool write(std::uint64_t at);

    const GlApi& gl_;
    UploadPath path_;
    unsigned ring_ = 0;
    std::uint64_t size_ = 0;
    std::uint64_t head_ = 0;
    void* mapped_ = nullptr;  ///< persistent path
    std::deque<Region> busy_; ///< oldest first
    std::vector<unsigned char> staged_;
    std::vector<Copy> copies_;
    std::vector<unsigned> retired_; ///< moved from: deleted after the flush issues their copies
    RingStats stats_;
};

} // namespace terrain::render
