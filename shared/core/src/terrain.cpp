#include "byte_io.h"

#include <terrain/terrain.h>

#define XXH_STATIC_LINKING_ONLY // XXH3_state_t on the stack
#include <xxhash.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cstring>
#include <string>

namespace terrain {
namespace {

std::string cellName(std::int32_t cx, std::int32_t cy) {
    return "cell (" + std::to_string(cx) + ", " + std::to_string(cy) + ")";
}

} // namespace

Result<Terrain>
Terrain::createUnhashed(const WorldSpec& spec, std::span<const std::int32_t> samples) {
    if (auto status = spec.validate(); !status)
        return status.error();
    const auto expected =
        static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height);
    if (samples.size() != expected)
        return makeError(
            ErrorCode::kSizeMismatch,
            "expected " + std::to_string(expected) + " samples for " + std::to_string(spec.width) +
                " x " + std::to_string(spec.height) + ", got " + std::to_string(samples.size()));
    for (std::size_t i = 0; i < samples.size(); ++i)
        if (samples[i] > kMaxHeightQuanta || samples[i] < -kMaxHeightQuanta)
            return makeError(
                ErrorCode::kOutOfRange,
                "sample " + std::to_string(i) + " = " + std::to_string(samples[i]) +
                    " quanta is beyond the height limit of +-" + std::to_string(kMaxHeightQuanta));

    Terrain t;
    t.spec_ = spec;
    t.padded_width_ = spec.paddedWidth();
    const std::int32_t ph = spec.paddedHeight();
    t.samples_.resize(static_cast<std::size_t>(t.padded_width_) * static_cast<std::size_t>(ph));
    for (std::int32_t y = 0; y < ph; ++y) {
        const std::int32_t sy = std::min(y, spec.height - 1);
        for (std::int32_t x = 0; x < t.padded_width_; ++x) {
            const std::int32_t sx = std::min(x, spec.width - 1);
            t.setSample(
                x, y,
                samples
                    [static_cast<std::size_t>(sy) * static_cast<std::size_t>(spec.width) +
                     static_cast<std::size_t>(sx)]);
        }
    }
    t.original_ = std::make_shared<std::vector<std::int32_t>>(t.samples_);
    t.tiles_.resize(static_cast<std::size_t>(spec.tileCount()));
    return t;
}

Result<Terrain> Terrain::create(const WorldSpec& spec, std::span<const std::int32_t> samples) {
    Result<Terrain> t = createUnhashed(spec, samples);
    if (!t)
        return t;
    for (std::int32_t tile = 0; tile < spec.tileCount(); ++tile)
        t->rehashTile(tile);
    t->rehashWorld();
    return t;
}

const DetailPatch* Terrain::findPatch(std::int32_t cx, std::int32_t cy) const {
    const auto& patches = *tiles_[static_cast<std::size_t>(tileOfCell(cx, cy))].patches;
    if (patches.empty())
        return nullptr;
    const std::uint16_t cell = localCell(cx, cy);
    const auto it = std::lower_bound(
        patches.begin(), patches.end(), cell,
        [](const PatchEntry& e, std::uint16_t c) { return e.cell < c; });
    return (it != patches.end() && it->cell == cell) ? &it->patch : nullptr;
}

std::ptrdiff_t Terrain::mergeTilePatches(
    std::vector<PatchEntry>& patches,
    std::span<const PatchChange> changes,
    std::vector<PatchEntry>& merged) {
    // a battle's shots mostly reshape patches the tile holds already: those are written in
    // place, where a merge would copy the whole list (thousands of patches) twice
    const auto findCell = [&](std::uint16_t cell) {
        return std::lower_bound(
            patches.begin(), patches.end(), cell,
            [](const PatchEntry& e, std::uint16_t c) { return e.cell < c; });
    };
    const bool in_place = std::all_of(changes.begin(), changes.end(), [&](const PatchChange& c) {
        const auto it = findCell(c.cell);
        return !c.erase && it != patches.end() && it->cell == c.cell;
    });
    if (in_place) {
        for (const PatchChange& c : changes)
            findCell(c.cell)->patch = c.patch;
        return 0;
    }
    merged.clear();
    merged.reserve(patches.size() + changes.size());
    std::ptrdiff_t delta = 0;
    auto old = patches.begin();
    for (const PatchChange& change : changes) {
        while (old != patches.end() && old->cell < change.cell)
            merged.push_back(*old++);
        const bool present = old != patches.end() && old->cell == change.cell;
        if (present)
            ++old;
        if (!change.erase)
            merged.push_back(PatchEntry{change.cell, change.patch});
        delta += (change.erase ? 0 : 1) - (present ? 1 : 0);
    }
    merged.insert(merged.end(), old, patches.end());
    // copied back rather than swapped: a tile keeps a buffer of its own size, not the scratch's
    // (memoryUsage counts capacity)
    patches.assign(merged.begin(), merged.end());
    return delta;
}

void Terrain::applyPatchChanges(std::span<const PatchChange> changes, TaskRunner* runner) {
    std::vector<std::size_t> starts; // each tile's first change
    for (std::size_t c = 0; c < changes.size(); ++c)
        if (c == 0 || changes[c].tile != changes[c - 1].tile)
            starts.push_back(c);
    starts.push_back(changes.size());
    const std::size_t groups = starts.size() - 1;
    auto group = [&](std::size_t g) {
        return changes.subspan(starts[g], starts[g + 1] - starts[g]);
    };
    if (runner == nullptr || runner->threads() <= 1 || groups < 2) {
        for (std::size_t g = 0; g < groups; ++g) {
            const auto tile = static_cast<std::size_t>(changes[starts[g]].tile);
            patch_count_ = static_cast<std::size_t>(
                static_cast<std::ptrdiff_t>(patch_count_) +
                mergeTilePatches(mutablePatches(tile), group(g), merge_scratch_));
        }
        return;
    }
    std::vector<std::ptrdiff_t> deltas(groups);
    runner->run(groups, [&](std::size_t g) {
        std::vector<PatchEntry> merged;
        const auto tile = static_cast<std::size_t>(changes[starts[g]].tile);
        deltas[g] = mergeTilePatches(mutablePatches(tile), group(g), merged);
    });
    for (std::ptrdiff_t d : deltas)
        patch_count_ = static_cast<std::size_t>(static_cast<std::ptrdiff_t>(patch_count_) + d);
}

void Terrain::appendTileBytes(std::int32_t tile, std::vector<std::uint8_t>& out) const {
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    detail::putU32(out, static_cast<std::uint32_t>(tx));
    detail::putU32(out, static_cast<std::uint32_t>(ty));
    // samples: sized once and written row by row (a plain copy on little-endian hosts, whose
    // memory layout is the canonical one)
    std::size_t at = out.size();
    out.resize(at + kTileVertices * kTileVertices * sizeof(std::int32_t));
    for (std::int32_t y = 0; y < kTileVertices; ++y) {
        const std::int32_t* row = &samples_
                                      [static_cast<std::size_t>(ty * kTileCells + y) *
                                           static_cast<std::size_t>(padded_width_) +
                                       static_cast<std::size_t>(tx * kTileCells)];
        if constexpr (std::endian::native == std::endian::little) {
            std::memcpy(out.data() + at, row, kTileVertices * sizeof(std::int32_t));
            at += kTileVertices * sizeof(std::int32_t);
        } else {
            for (std::int32_t x = 0; x < kTileVertices; ++x)
                for (int b = 0; b < 32; b += 8)
                    out[at++] = static_cast<std::uint8_t>(static_cast<std::uint32_t>(row[x]) >> b);
        }
    }
    // displacements from the original ground, row by row
    for (std::int32_t y = 0; y < kTileVertices; ++y)
        for (std::int32_t x = 0; x < kTileVertices; ++x) {
            const std::int32_t vx = tx * kTileCells + x;
            const std::int32_t vy = ty * kTileCells + y;
            detail::putI32(out, sample(vx, vy) - original(vx, vy));
        }
    const auto& patches = *tiles_[static_cast<std::size_t>(tile)].patches;
    detail::putU32(out, static_cast<std::uint32_t>(patches.size()));
    // patches: sized once as well (byte-wise appends were a quarter of a crater storm's time)
    constexpr std::size_t kControlBytes = sizeof(std::int32_t) * kPatchControls;
    at = out.size();
    out.resize(at + patches.size() * (sizeof(std::uint16_t) + kControlBytes));
    for (const PatchEntry& e : patches) {
        out[at++] = static_cast<std::uint8_t>(e.cell);
        out[at++] = static_cast<std::uint8_t>(e.cell >> 8);
        if constexpr (std::endian::native == std::endian::little) {
            std::memcpy(out.data() + at, e.patch.control.data(), kControlBytes);
            at += kControlBytes;
        } else {
            for (std::int32_t c : e.patch.control)
                for (int b = 0; b < 32; b += 8)
                    out[at++] = static_cast<std::uint8_t>(static_cast<std::uint32_t>(c) >> b);
        }
    }
}

namespace {

std::uint64_t hashWorld(
    const WorldSpec& spec,
    std::span<const std::uint64_t> tile_hashes,
    std::vector<std::uint8_t>& scratch) {
    // the world hash covers the spec, so replicas of different worlds never agree by accident
    scratch.clear();
    for (std::int32_t v :
         {spec.width, spec.height, spec.spacing, spec.units_per_metre, spec.patch_tolerance})
        detail::putI32(scratch, v);
    for (std::uint64_t h : tile_hashes)
        detail::putU64(scratch, h);
    return XXH3_64bits(scratch.data(), scratch.size());
}

} // namespace

void Terrain::rehashTile(std::int32_t tile) {
    Tile& t = tiles_[static_cast<std::size_t>(tile)];
    t.hash = streamTileHash(tile);
    t.version = nextTileVersion();
}

std::uint64_t Terrain::nextTileVersion() {
    static std::atomic<std::uint64_t> last{0};
    return last.fetch_add(1, std::memory_order_relaxed) + 1;
}

std::vector<PatchEntry>& Terrain::mutablePatches(std::size_t tile) {
    std::shared_ptr<std::vector<PatchEntry>>& patches = tiles_[tile].patches;
    if (patches.use_count() > 1)
        patches = std::make_shared<std::vector<PatchEntry>>(*patches);
    else
        // the other owner's release (its destructor on the snapshot thread) happens before
        // this write: use_count() alone is a relaxed load
        std::atomic_thread_fence(std::memory_order_acquire);
    return *patches;
}

Terrain::SampleRect Terrain::tileSamples(std::int32_t tile) const {
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    const auto rows =
        static_cast<std::int32_t>(samples_.size() / static_cast<std::size_t>(padded_width_));
    SampleRect r;
    r.x0 = tx * kTileCells;
    r.x1 = tx + 1 == spec_.tilesX() ? padded_width_ : r.x0 + kTileCells;
    r.y0 = ty * kTileCells;
    r.y1 = ty + 1 == spec_.tilesY() ? rows : r.y0 + kTileCells;
    return r;
}

std::size_t Terrain::syncFrom(const Terrain& from) {
    if (this == &from)
        return 0;
    if (!(spec_ == from.spec_) || samples_.size() != from.samples_.size() ||
        tiles_.size() != from.tiles_.size()) {
        *this = from;
        return tiles_.size();
    }
    // a change to a shared edge vertex renews the versions of every tile that holds it, so the
    // changed tiles' rectangles hold every change
    std::size_t copied = 0;
    for (std::int32_t tile = 0; tile < spec_.tileCount(); ++tile) {
        Tile& mine = tiles_[static_cast<std::size_t>(tile)];
        const Tile& theirs = from.tiles_[static_cast<std::size_t>(tile)];
        if (mine.version == theirs.version)
            continue;
        mine = theirs;
        ++copied;
        const SampleRect r = tileSamples(tile);
        for (std::int32_t y = r.y0; y < r.y1; ++y) {
            const auto at = static_cast<std::ptrdiff_t>(sampleIndex(r.x0, y));
            std::copy_n(from.samples_.begin() + at, r.width(), samples_.begin() + at);
        }
    }
    original_ = from.original_;
    patch_count_ = from.patch_count_;
    world_hash_ = from.world_hash_;
    return copied;
}

Terrain::TileSync Terrain::takeSync(std::vector<std::uint64_t>& versions) const {
    TileSync sync;
    sync.original_ = original_;
    sync.patch_count_ = patch_count_;
    sync.world_hash_ = world_hash_;
    // a copy of another shape, or whose every tile differs (another world, a snapshot loaded:
    // its spec may differ even at the same tile count), takes the whole terrain
    bool whole = versions.size() != tiles_.size();
    if (!whole) {
        whole = true;
        for (std::size_t t = 0; t < tiles_.size() && whole; ++t)
            whole = tiles_[t].version != versions[t];
    }
    if (whole) {
        sync.whole_ = std::make_shared<const Terrain>(*this);
        versions.resize(tiles_.size());
        for (std::size_t t = 0; t < tiles_.size(); ++t)
            versions[t] = tiles_[t].version;
        return sync;
    }
    for (std::int32_t tile = 0; tile < spec_.tileCount(); ++tile) {
        const Tile& mine = tiles_[static_cast<std::size_t>(tile)];
        std::uint64_t& theirs = versions[static_cast<std::size_t>(tile)];
        if (mine.version == theirs)
            continue;
        theirs = mine.version;
        TileSync::TileCopy& copy = sync.tiles_.emplace_back();
        copy.tile = tile;
        copy.state = mine;
        const SampleRect r = tileSamples(tile);
        copy.samples.reserve(static_cast<std::size_t>(r.width() * (r.y1 - r.y0)));
        for (std::int32_t y = r.y0; y < r.y1; ++y) {
            const auto row = samples_.begin() + static_cast<std::ptrdiff_t>(sampleIndex(r.x0, y));
            copy.samples.insert(copy.samples.end(), row, row + r.width());
        }
    }
    return sync;
}

void Terrain::applySync(const TileSync& sync, PatchLists lists) {
    const auto own = [&](Tile& tile) {
        if (lists == PatchLists::kOwnCopies)
            tile.patches = std::make_shared<std::vector<PatchEntry>>(*tile.patches);
    };
    if (sync.whole_) {
        *this = *sync.whole_;
        for (Tile& tile : tiles_)
            own(tile);
        return;
    }
    for (const TileSync::TileCopy& copy : sync.tiles_) {
        tiles_[static_cast<std::size_t>(copy.tile)] = copy.state;
        own(tiles_[static_cast<std::size_t>(copy.tile)]);
        const SampleRect r = tileSamples(copy.tile);
        auto from = copy.samples.begin();
        for (std::int32_t y = r.y0; y < r.y1; ++y, from += r.width())
            std::copy_n(
                from, r.width(),
                samples_.begin() + static_cast<std::ptrdiff_t>(sampleIndex(r.x0, y)));
    }
    original_ = sync.original_;
    patch_count_ = sync.patch_count_;
    world_hash_ = sync.world_hash_;
}

std::size_t Terrain::TileSync::bytes() const {
    if (whole_)
        return whole_->samples_.size() * sizeof(std::int32_t);
    std::size_t n = 0;
    for (const TileCopy& copy : tiles_)
        n += copy.samples.size() * sizeof(std::int32_t);
    return n;
}

std::uint64_t Terrain::streamTileHash(std::int32_t tile, bool genesis) const {
    // the bytes of appendTileBytes, streamed in chunks of a stack buffer: a battle zone's tile
    // holds hundreds of kilobytes of patches, which were copied and zero-filled for every op
    XXH3_state_t state;
    XXH3_64bits_reset(&state);
    std::array<std::uint8_t, 8192> chunk{};
    std::size_t used = 0;
    auto flush = [&] {
        XXH3_64bits_update(&state, chunk.data(), used);
        used = 0;
    };
    auto put32 = [&](std::uint32_t v) {
        for (int b = 0; b < 32; b += 8)
            chunk[used++] = static_cast<std::uint8_t>(v >> b);
    };
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    put32(static_cast<std::uint32_t>(tx));
    put32(static_cast<std::uint32_t>(ty));
    const std::vector<std::int32_t>& ground = genesis ? *original_ : samples_;
    for (std::int32_t y = 0; y < kTileVertices; ++y) {
        const std::int32_t* row = &ground
                                      [static_cast<std::size_t>(ty * kTileCells + y) *
                                           static_cast<std::size_t>(padded_width_) +
                                       static_cast<std::size_t>(tx * kTileCells)];
        if (used + kTileVertices * sizeof(std::int32_t) > chunk.size())
            flush();
        if constexpr (std::endian::native == std::endian::little) {
            std::memcpy(chunk.data() + used, row, kTileVertices * sizeof(std::int32_t));
            used += kTileVertices * sizeof(std::int32_t);
        } else {
            for (std::int32_t x = 0; x < kTileVertices; ++x)
                put32(static_cast<std::uint32_t>(row[x]));
        }
    }
    for (std::int32_t y = 0; y < kTileVertices; ++y) {
        if (used + kTileVertices * sizeof(std::int32_t) > chunk.size())
            flush();
        for (std::int32_t x = 0; x < kTileVertices; ++x) {
            const std::int32_t vx = tx * kTileCells + x;
            const std::int32_t vy = ty * kTileCells + y;
            put32(genesis ? 0u : static_cast<std::uint32_t>(sample(vx, vy) - original(vx, vy)));
        }
    }
    if (used + sizeof(std::uint32_t) > chunk.size())
        flush();
    if (genesis) {
        put32(0); // no patches
        flush();
        return XXH3_64bits_digest(&state);
    }
    const auto& patches = *tiles_[static_cast<std::size_t>(tile)].patches;
    put32(static_cast<std::uint32_t>(patches.size()));
    constexpr std::size_t kControlBytes = sizeof(std::int32_t) * kPatchControls;
    for (const PatchEntry& e : patches) {
        if (used + sizeof(std::uint16_t) + kControlBytes > chunk.size())
            flush();
        chunk[used++] = static_cast<std::uint8_t>(e.cell);
        chunk[used++] = static_cast<std::uint8_t>(e.cell >> 8);
        if constexpr (std::endian::native == std::endian::little) {
            std::memcpy(chunk.data() + used, e.patch.control.data(), kControlBytes);
            used += kControlBytes;
        } else {
            for (std::int32_t c : e.patch.control)
                put32(static_cast<std::uint32_t>(c));
        }
    }
    flush();
    return XXH3_64bits_digest(&state);
}

void Terrain::rehashWorld() {
    tile_hashes_.resize(tiles_.size());
    for (std::size_t i = 0; i < tiles_.size(); ++i)
        tile_hashes_[i] = tiles_[i].hash;
    world_hash_ = hashWorld(spec_, tile_hashes_, scratch_);
}

std::uint64_t Terrain::genesisHash() const {
    std::vector<std::uint64_t> hashes(tiles_.size());
    for (std::size_t i = 0; i < tiles_.size(); ++i)
        hashes[i] = streamTileHash(static_cast<std::int32_t>(i), true);
    std::vector<std::uint8_t> scratch;
    return hashWorld(spec_, hashes, scratch);
}

bool Terrain::differsFromGenesis(std::int32_t tile) const {
    if (!tiles_[static_cast<std::size_t>(tile)].patches->empty())
        return true;
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    for (std::int32_t y = 0; y < kTileVertices; ++y) {
        const std::size_t row = static_cast<std::size_t>(ty * kTileCells + y) *
                                    static_cast<std::size_t>(padded_width_) +
                                static_cast<std::size_t>(tx * kTileCells);
        if (!std::equal(
                samples_.begin() + static_cast<std::ptrdiff_t>(row),
                samples_.begin() + static_cast<std::ptrdiff_t>(row + kTileVertices),
                original_->begin() + static_cast<std::ptrdiff_t>(row)))
            return true;
    }
    return false;
}

std::uint64_t Terrain::computeTileHash(std::int32_t tile) const {
    std::vector<std::uint8_t> bytes;
    appendTileBytes(tile, bytes);
    return XXH3_64bits(bytes.data(), bytes.size());
}

std::uint64_t Terrain::computeWorldHash() const {
    std::vector<std::uint64_t> hashes(tiles_.size());
    for (std::size_t i = 0; i < tiles_.size(); ++i)
        hashes[i] = computeTileHash(static_cast<std::int32_t>(i));
    std::vector<std::uint8_t> scratch;
    return hashWorld(spec_, hashes, scratch);
}

MemoryUsage Terrain::memoryUsage() const {
    MemoryUsage m;
    m.sample_bytes = samples_.capacity() * sizeof(std::int32_t);
    m.original_bytes = original_->capacity() * sizeof(std::int32_t);
    m.tile_bytes = tiles_.capacity() * sizeof(Tile);
    for (const Tile& t : tiles_)
        m.patch_bytes += t.patches->capacity() * sizeof(PatchEntry);
    return m;
}

void Terrain::loadTile(
    std::int32_t tile,
    std::span<const std::int32_t> samples65,
    std::span<const std::int32_t> originals65,
    std::vector<PatchEntry> patches) {
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    std::vector<std::int32_t>& original = mutableOriginal();
    for (std::int32_t y = 0; y < kTileVertices; ++y)
        for (std::int32_t x = 0; x < kTileVertices; ++x) {
            const auto i = static_cast<std::size_t>(y * kTileVertices + x);
            setSample(tx * kTileCells + x, ty * kTileCells + y, samples65[i]);
            original
                [static_cast<std::size_t>(ty * kTileCells + y) *
                     static_cast<std::size_t>(padded_width_) +
                 static_cast<std::size_t>(tx * kTileCells + x)] = originals65[i];
        }
    Tile& slot = tiles_[static_cast<std::size_t>(tile)];
    patch_count_ -= slot.patches->size();
    slot.patches = std::make_shared<std::vector<PatchEntry>>(std::move(patches));
    patch_count_ += slot.patches->size();
    slot.version = nextTileVersion();
}

void Terrain::refreshBounds(std::int32_t tile) {
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    for (PatchEntry& e : mutablePatches(static_cast<std::size_t>(tile)))
        updateBounds(
            e.patch,
            corners(tx * kTileCells + e.cell % kTileCells, ty * kTileCells + e.cell / kTileCells));
}

void Terrain::refreshTile(std::int32_t tile) {
    refreshBounds(tile);
    rehashTile(tile);
}

void Terrain::rehashAll() {
    for (std::int32_t tile = 0; tile < spec_.tileCount(); ++tile)
        refreshTile(tile);
    rehashWorld();
}

std::vector<std::int32_t>& Terrain::mutableOriginal() {
    // shared with a copy (a snapshot being encoded on another thread): this one gets its own
    if (original_.use_count() > 1)
        original_ = std::make_shared<std::vector<std::int32_t>>(*original_);
    else
        // as in mutablePatches: the other owner's release happens before this write
        std::atomic_thread_fence(std::memory_order_acquire);
    return *original_;
}

void Terrain::replaceTile(
    std::int32_t tile,
    std::span<const std::int32_t> samples65,
    std::span<const std::int32_t> originals65,
    std::vector<PatchEntry> patches) {
    loadTile(tile, samples65, originals65, std::move(patches));
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    // edge vertices are shared: neighbouring tiles' bytes and patch bounds may have changed too
    for (std::int32_t ny = std::max(0, ty - 1); ny <= std::min(spec_.tilesY() - 1, ty + 1); ++ny)
        for (std::int32_t nx = std::max(0, tx - 1); nx <= std::min(spec_.tilesX() - 1, tx + 1);
             ++nx)
            refreshTile(ny * spec_.tilesX() + nx);
    rehashWorld();
}

Status Terrain::checkInvariants() const {
    // per tile, a local cell -> patch table makes the in-tile neighbour lookups O(1); only the
    // border cells' neighbours in other tiles need findPatch() (a snapshot join with 270k
    // patches spent 90 ms here in binary searches)
    std::vector<const DetailPatch*> local(static_cast<std::size_t>(kTileCells * kTileCells));
    for (std::int32_t tile = 0; tile < spec_.tileCount(); ++tile) {
        const std::int32_t tx = tile % spec_.tilesX();
        const std::int32_t ty = tile / spec_.tilesX();
        const auto& patches = *tiles_[static_cast<std::size_t>(tile)].patches;
        if (patches.empty())
            continue;
        std::fill(local.begin(), local.end(), nullptr);
        for (const PatchEntry& e : patches)
            local[e.cell] = &e.patch;
        const auto neighbour = [&](std::int32_t nx, std::int32_t ny) -> const DetailPatch* {
            if (nx / kTileCells == tx && ny / kTileCells == ty)
                return local[static_cast<std::size_t>(localCell(nx, ny))];
            return findPatch(nx, ny);
        };
        for (const PatchEntry& e : patches) {
            const std::int32_t cx = tx * kTileCells + e.cell % kTileCells;
            const std::int32_t cy = ty * kTileCells + e.cell / kTileCells;
            if (cx >= spec_.cellsX() || cy >= spec_.cellsY())
                return makeError(
                    ErrorCode::kInvariantBroken, cellName(cx, cy) + " is outside the map");
            const CellCorners c = corners(cx, cy);
            if (!areCornersPinned(e.patch, c))
                return makeError(
                    ErrorCode::kInvariantBroken,
                    cellName(cx, cy) + ": patch corners are not pinned to the base samples");
            for (Edge edge : kAllEdges) {
                const CellOffset off = neighbourOffset(edge);
                const std::int32_t nx = cx + off.dx;
                const std::int32_t ny = cy + off.dy;
                if (nx < 0 || ny < 0 || nx >= spec_.cellsX() || ny >= spec_.cellsY())
                    continue; // the map edge has no neighbour to agree with
                if (const DetailPatch* n = neighbour(nx, ny)) {
                    if (off.dx < 0 || off.dy < 0)
                        continue; // a shared border is compared once, from its lower cell
                    for (int k = 0; k < bspline::kControls; ++k)
                        if (edgeControl(e.patch, edge, k) != edgeControl(*n, opposite(edge), k))
                            return makeError(
                                ErrorCode::kInvariantBroken,
                                cellName(cx, cy) + ": border differs from the neighbour patch");
                } else if (!isEdgeStraight(e.patch, edge, c)) {
                    return makeError(
                        ErrorCode::kInvariantBroken,
                        cellName(cx, cy) + ": border next to a base cell is not straight");
                }
            }
        }
    }
    return Ok{};
}

} // namespace terrain
