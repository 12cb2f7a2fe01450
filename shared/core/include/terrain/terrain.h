#pragma once

// The authoritative terrain state: the padded fixed-point height grid, sparse detail patches
// per tile, and the tile and world hashes. Server and client hold one each and keep them equal
// by applying the same DeformOps.
// Pure: no I/O, no clocks, no globals. Not thread safe; one owner mutates it.

#include <terrain/deform_op.h>
#include <terrain/detail_patch.h>
#include <terrain/result.h>
#include <terrain/task_runner.h>
#include <terrain/world_spec.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace terrain {

/// A patch and the cell it belongs to, local to its tile (y * kTileCells + x).
struct PatchEntry {
    std::uint16_t cell = 0;
    DetailPatch patch;
};

/// Inclusive rectangle of cells or vertices.
struct CellRect {
    std::int32_t x0 = 0;
    std::int32_t y0 = 0;
    std::int32_t x1 = -1;
    std::int32_t y1 = -1;
    bool empty() const { return x1 < x0 || y1 < y0; }
};

/// What one op changed; the client replica turns it into re-tessellation work.
struct OpEffect {
    CellRect vertices;                     ///< base vertices the op may have changed
    CellRect cells;                        ///< cells whose surface may have changed
    std::vector<std::int32_t> dirty_tiles; ///< tile indices whose hash changed, ascending
    std::int32_t vertices_changed = 0;
    std::int32_t patches_created = 0;
    std::int32_t patches_removed = 0;
    std::int32_t patches_changed = 0;
};

struct MemoryUsage {
    std::size_t sample_bytes = 0;   ///< the base grid (padded)
    std::size_t original_bytes = 0; ///< the original ground (padded), the craters' reference
    std::size_t patch_bytes = 0;    ///< patch entries in use
    std::size_t tile_bytes = 0;     ///< per-tile bookkeeping (hash, patch vector headers)
    std::size_t total() const { return sample_bytes + original_bytes + patch_bytes + tile_bytes; }
};

inline constexpr std::size_t kBytesPerPatch = sizeof(PatchEntry);

struct DecodedSnapshot; // snapshot.h

class Terrain {
  public:
    /// Builds a flat-patchless terrain from `samples` (width * height, row-major, quanta).
    /// Samples beyond the map are padded by repeating the last row and column.
    /// Errors: the spec's own rules; kSizeMismatch when samples.size() != width * height;
    /// kOutOfRange for a sample beyond +-kMaxHeightQuanta.
    static Result<Terrain> create(const WorldSpec& spec, std::span<const std::int32_t> samples);

    const WorldSpec& spec() const { return spec_; }

    /// Base sample at vertex (x, y) of the padded grid.
    std::int32_t sample(std::int32_t x, std::int32_t y) const {
        return samples_
            [static_cast<std::size_t>(y) * static_cast<std::size_t>(padded_width_) +
             static_cast<std::size_t>(x)];
    }
    CellCorners corners(std::int32_t cx, std::int32_t cy) const {
        return {sample(cx, cy), sample(cx + 1, cy), sample(cx, cy + 1), sample(cx + 1, cy + 1)};
    }
    std::span<const std::int32_t> paddedSamples() const { return samples_; }

    /// The original ground at vertex (x, y): the samples the world was created with. Craters
    /// measure how deep they may dig and how high they may throw from it; it changes only
    /// through snapshots and repairs, which carry it.
    std::int32_t original(std::int32_t x, std::int32_t y) const {
        return (*original_)
            [static_cast<std::size_t>(y) * static_cast<std::size_t>(padded_width_) +
             static_cast<std::size_t>(x)];
    }
    CellCorners originalCorners(std::int32_t cx, std::int32_t cy) const {
        return {
            original(cx, cy), original(cx + 1, cy), original(cx, cy + 1), original(cx + 1, cy + 1)};
    }

    /// The patch of cell (cx, cy), or nullptr where the base triangles are the surface.
    const DetailPatch* findPatch(std::int32_t cx, std::int32_t cy) const;
    std::size_t patchCount() const { return patch_count_; }
    /// Patches of tile t in ascending local cell order.
    std::span<const PatchEntry> tilePatches(std::int32_t tile) const {
        return *tiles_[static_cast<std::size_t>(tile)].patches;
    }

    std::uint64_t tileHash(std::int32_t tile) const {
        return tiles_[static_cast<std::size_t>(tile)].hash;
    }
    std::uint64_t worldHash() const { return world_hash_; }
    /// The world hash of the genesis: the original ground with no op on it (no displacement, no
    /// patches), the world as it was created. Clients that hold it join by a genesis delta
    /// (genesis_delta.h). Hashes the whole map: callers cache it.
    std::uint64_t genesisHash() const;
    /// True when tile t differs from the genesis: a sample moved off the original ground
    /// (shared edge vertices included) or a patch.
    bool differsFromGenesis(std::int32_t tile) const;

    /// Hashes recomputed from the current state, ignoring the incremental ones (for checks and
    /// benchmarks; allocates a scratch buffer).
    std::uint64_t computeTileHash(std::int32_t tile) const;
    std::uint64_t computeWorldHash() const;

    /// Validates and applies one op. On error nothing changes. Defined in deformation.cpp.
    /// With a `runner`, the op's cells are judged, its patches bounded and merged and its tiles
    /// hashed on the runner's threads: each task writes only its own cells or tile, so the bits
    /// are those of the serial path (tested at 1 to 8 threads).
    Result<OpEffect> apply(const DeformOp& op, TaskRunner* runner = nullptr);

    /// Canonical little-endian bytes of tile t: the input of its hash and a snapshot chunk.
    /// Layout: u32 tile x, u32 tile y, 65 x 65 i32 samples row-major, 65 x 65 i32 displacements
    /// (sample - original ground: zero wherever no op has been, so it compresses to nothing),
    /// u32 patch count, then per patch u16 local cell and 25 i32 controls.
    void appendTileBytes(std::int32_t tile, std::vector<std::uint8_t>& out) const;

    MemoryUsage memoryUsage() const;

    /// Replaces tile t's samples, original ground and patches from decoded canonical bytes
    /// (snapshot, repair). The caller has validated the patch invariants; rehashes the tile and
    /// the world.
    void replaceTile(
        std::int32_t tile,
        std::span<const std::int32_t> samples65,
        std::span<const std::int32_t> originals65,
        std::vector<PatchEntry> patches);

    /// Checks every patch invariant (pinned corners, borders shared or straight). Used after
    /// decoding untrusted state. The error names the first cell that breaks one.
    Status checkInvariants() const;

    /// Makes this terrain equal to `from` (as `*this = from` would), copying only the tiles
    /// that changed since the two were last equal: a copy kept for snapshots follows its
    /// source at the cost of what changed, not of the world. Patch lists are shared, not
    /// copied (the first later write to one, on either side, clones it). Returns the tiles
    /// copied. Not thread-safe against writers of either terrain.
    std::size_t syncFrom(const Terrain& from);

    class TileSync;
    /// syncFrom in two halves, for a copy on another thread: takes the tiles whose version
    /// differs from `versions` (the copy's, one per tile: resized and brought to this
    /// terrain's), and the world's totals; or, when the copy holds no terrain of this shape
    /// (`versions` empty or of another size), the whole terrain. The copy applies it with
    /// applySync. The cost of the changed tiles: their samples copied, their patch lists shared.
    TileSync takeSync(std::vector<std::uint64_t>& versions) const;
    /// How a copy holds the patch lists a sync brings.
    enum class PatchLists {
        kShared,    ///< shared with the source, copy-on-write: no second copy in memory
        kOwnCopies, ///< copied here: the source, once the sync is gone, writes its lists in
                    ///< place instead of cloning them on its next write (its thread is the
                    ///< one that must not pay for the copy)
    };
    /// Makes this terrain equal to the one `sync` was taken from, when this one was equal to
    /// it at the versions the taker tracked (syncs apply in the order taken).
    void applySync(const TileSync& sync, PatchLists lists = PatchLists::kShared);

  private:
    struct Tile {
        // ascending by cell; shared with copies of the terrain (a snapshot's), cloned before a
        // write while shared (mutablePatches)
        std::shared_ptr<std::vector<PatchEntry>> patches =
            std::make_shared<std::vector<PatchEntry>>();
        std::uint64_t hash = 0;
        // unique across every terrain in the process, renewed on each change of the tile's
        // bytes: equal versions mean the same bytes (copies carry them; syncFrom skips those)
        std::uint64_t version = nextTileVersion();
    };
    static std::uint64_t nextTileVersion();

    // apply()'s stages, in order, over one op in flight (deformation.cpp)
    struct ApplyScratch;
    void measureFootprint(ApplyScratch& s) const;
    void computeNewSamples(ApplyScratch& s) const;
    void judgeCells(ApplyScratch& s, TaskRunner* runner) const;
    void transformPatch(
        const ApplyScratch& s,
        DetailPatch& p,
        std::int32_t cx,
        std::int32_t cy,
        const CellCorners& co,
        const CellCorners& cn,
        bool from_base) const;
    void enforceBorders(ApplyScratch& s) const;
    void commitOp(ApplyScratch& s, TaskRunner* runner);
    /// Tile t's patches for writing: its own list, cloned first when a copy still shares it.
    std::vector<PatchEntry>& mutablePatches(std::size_t tile);

    Terrain() = default;

    friend Result<DecodedSnapshot> decodeSnapshot(std::span<const std::uint8_t> bytes);
    friend Result<DecodedSnapshot>
    decodeGenesisDelta(std::span<const std::uint8_t> bytes, const Terrain& holder);
    /// create() without the tile and world hashes (decodeSnapshot sets them from its records).
    static Result<Terrain>
    createUnhashed(const WorldSpec& spec, std::span<const std::int32_t> samples);
    /// Writes a tile's samples, original ground and patches without rehashing anything.
    void loadTile(
        std::int32_t tile,
        std::span<const std::int32_t> samples65,
        std::span<const std::int32_t> originals65,
        std::vector<PatchEntry> patches);
    void rehashAll();
    /// Recomputes the derived bounds of a tile's patches.
    void refreshBounds(std::int32_t tile);
    /// refreshBounds(), then the tile's hash (not the world hash).
    void refreshTile(std::int32_t tile);

    /// The half-open rectangle of padded samples that tile t owns: every sample belongs to one
    /// tile's (the last row and column of tiles take the grid's last vertex line and the
    /// padding), so copying a changed tile's rectangle copies every change it holds.
    struct SampleRect {
        std::int32_t x0 = 0;
        std::int32_t x1 = 0;
        std::int32_t y0 = 0;
        std::int32_t y1 = 0;
        std::int32_t width() const { return x1 - x0; }
    };
    SampleRect tileSamples(std::int32_t tile) const;
    /// Index of sample (x, y) in samples_.
    std::size_t sampleIndex(std::int32_t x, std::int32_t y) const {
        return static_cast<std::size_t>(y) * static_cast<std::size_t>(padded_width_) +
               static_cast<std::size_t>(x);
    }

    std::int32_t tileOfCell(std::int32_t cx, std::int32_t cy) const {
        return (cy / kTileCells) * spec_.tilesX() + cx / kTileCells;
    }
    static std::uint16_t localCell(std::int32_t cx, std::int32_t cy) {
        return static_cast<std::uint16_t>((cy % kTileCells) * kTileCells + cx % kTileCells);
    }
    void setSample(std::int32_t x, std::int32_t y, std::int32_t value) {
        samples_
            [static_cast<std::size_t>(y) * static_cast<std::size_t>(padded_width_) +
             static_cast<std::size_t>(x)] = value;
    }
    /// A patch to insert or replace (`patch` set) or to erase, in a tile.
    struct PatchChange {
        std::int32_t tile = 0;
        std::uint16_t cell = 0;
        bool erase = false;
        DetailPatch patch;
    };
    /// One tile's patches with its sorted changes merged in, through `merged`; returns the
    /// change in the tile's patch count.
    static std::ptrdiff_t mergeTilePatches(
        std::vector<PatchEntry>& patches,
        std::span<const PatchChange> changes,
        std::vector<PatchEntry>& merged);
    /// Applies changes sorted by (tile, cell), merging each tile's list once: a battle zone's
    /// tiles hold thousands of patches, and one insert at a time moved them all each time.
    /// The tiles on `runner` when there are several.
    void applyPatchChanges(std::span<const PatchChange> changes, TaskRunner* runner = nullptr);
    void rehashTile(std::int32_t tile);
    /// XXH3-64 of appendTileBytes(tile), without building the bytes; with `genesis`, of the
    /// bytes the tile had at creation (samples = original ground, no displacement, no patches).
    std::uint64_t streamTileHash(std::int32_t tile, bool genesis = false) const;
    void rehashWorld();

    WorldSpec spec_;
    std::int32_t padded_width_ = 0;
    std::vector<std::int32_t> samples_;
    // the samples at creation, padded the same way: shared by copies (a snapshot's copy of the
    // world copies the pointer), cloned before a repair writes it (mutableOriginal)
    std::shared_ptr<std::vector<std::int32_t>> original_ =
        std::make_shared<std::vector<std::int32_t>>();
    std::vector<std::int32_t>& mutableOriginal();
    std::vector<Tile> tiles_;
    std::size_t patch_count_ = 0;
    std::uint64_t world_hash_ = 0;
    std::vector<std::uint8_t> scratch_;      // reused for tile bytes when hashing
    std::vector<std::uint64_t> tile_hashes_; // reused by rehashWorld
    std::vector<PatchEntry> merge_scratch_;  // reused by applyPatchChanges
};

/// What Terrain::takeSync took: opaque, movable, applied by Terrain::applySync.
class Terrain::TileSync {
  public:
    /// Tiles it carries (all of them for a whole terrain).
    std::size_t tileCount() const { return whole_ ? whole_->tiles_.size() : tiles_.size(); }
    /// Bytes it holds beside the shared lists (a whole terrain: its samples).
    std::size_t bytes() const;
    /// It carries the whole terrain (the copy held none of its shape): wholeTerrain() is it.
    bool whole() const { return whole_ != nullptr; }
    const Terrain& wholeTerrain() const { return *whole_; }

  private:
    friend class Terrain;
    struct TileCopy {
        std::int32_t tile = 0;
        Tile state;
        std::vector<std::int32_t> samples; ///< the tile's half-open rectangle, row by row
    };
    std::shared_ptr<const Terrain> whole_; ///< set when the copy held no terrain of this shape
    std::vector<TileCopy> tiles_;
    std::shared_ptr<std::vector<std::int32_t>> original_;
    std::size_t patch_count_ = 0;
    std::uint64_t world_hash_ = 0;
};

} // namespace terrain
