#pragma once

// Snapshots on the wire: SnapshotBegin + N SnapshotChunk frames whose data, concatenated, is one
// zstd frame of the core snapshot bytes. The server builds the frames once per seq and every
// joining session shares them; the client reassembles with SnapshotAssembler.

#include <terrain/result.h>
#include <terrain/snapshot.h>
#include <terrain/wire/codec.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace terrain::wire {

inline constexpr std::size_t kDefaultSnapshotChunkBytes = std::size_t{256} << 10;

struct SnapshotFrames {
    std::uint64_t seq = 0;
    std::uint64_t world_hash = 0;
    std::uint64_t genesis_hash = 0; ///< set: a genesis delta on that genesis (genesis_delta.h)
    std::uint64_t raw_bytes = 0;
    std::uint64_t compressed_bytes = 0;
    std::vector<Frame> frames; ///< begin, then the chunks
    std::size_t totalBytes() const;
};

SnapshotFrames buildSnapshotFrames(
    const Terrain& terrain,
    std::uint64_t seq,
    std::size_t chunk_bytes = kDefaultSnapshotChunkBytes);

/// The same for a client that holds the genesis `genesis_hash` (terrain.genesisHash()): the
/// frames carry a genesis delta.
SnapshotFrames buildGenesisDeltaFrames(
    const Terrain& terrain,
    std::uint64_t seq,
    std::uint64_t genesis_hash,
    std::size_t chunk_bytes = kDefaultSnapshotChunkBytes);

/// Largest core snapshot a world of this spec can have (every cell patched): the client's bound
/// on what a server may announce.
std::uint64_t maxSnapshotBytes(const WorldSpec& spec);
/// The larger of maxSnapshotBytes and maxGenesisDeltaBytes: the limit for either kind.
std::uint64_t maxSnapshotOrDeltaBytes(const WorldSpec& spec);

/// Client side. Refuses out-of-order chunks, more data than announced, and sizes above limits.
/// Chunks are decompressed as they arrive (zstd streaming), so decompression overlaps the
/// transfer and the compressed bytes are never held whole.
class SnapshotAssembler {
  public:
    explicit SnapshotAssembler(std::size_t max_raw_bytes);
    ~SnapshotAssembler();
    SnapshotAssembler(const SnapshotAssembler&) = delete;
    SnapshotAssembler& operator=(const SnapshotAssembler&) = delete;

    /// Errors: kOutOfRange (sizes above the limit), kBadFormat (no chunks).
    Status begin(const pb::SnapshotBegin& begin);
    /// Errors: kBadFormat (no begin, wrong index, more bytes than announced).
    Status add(const pb::SnapshotChunk& chunk);
    /// Lowers the limit (the client learns the world's size from Welcome).
    void setMaxRawBytes(std::size_t max_raw_bytes) { max_raw_bytes_ = max_raw_bytes; }
    bool active() const { return active_; }
    bool complete() const { return active_ && next_chunk_ == chunk_count_; }
    /// The genesis the snapshot being assembled is a delta on (0: a whole snapshot).
    std::uint64_t genesisHash() const { return genesis_hash_; }
    /// Decompresses and decodes (every core check); the result's seq and hash must equal the
    /// announced ones (kHashMismatch otherwise). A genesis delta is decoded on the genesis of
    /// `holder` (any state of the same world; kUnsupported when there is none). Resets the
    /// assembler either way.
    Result<DecodedSnapshot> finish(const Terrain* holder = nullptr);
    void reset();

  private:
    std::size_t max_raw_bytes_;
    bool active_ = false;
    std::uint64_t seq_ = 0;
    std::uint64_t world_hash_ = 0;
    std::uint64_t genesis_hash_ = 0;
    std::uint64_t raw_bytes_ = 0;
    std::uint64_t compressed_bytes_ = 0;
    std::uint32_t chunk_count_ = 0;
    std::uint32_t next_chunk_ = 0;
    std::uint64_t received_bytes_ = 0;
    std::size_t raw_filled_ = 0;
    bool frame_done_ = false;
    // note: allocated at the announced size but never initialised, so untouched pages cost no
    // memory: a server that lies about the size costs what it actually sends
    std::unique_ptr<std::uint8_t[]> raw_;
    struct Stream; // the zstd decompression context
    std::unique_ptr<Stream> stream_;
};

} // namespace terrain::wire
