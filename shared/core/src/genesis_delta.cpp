#include "byte_io.h"

#include <terrain/base_cell.h>
#include <terrain/bspline.h>
#include <terrain/detail_patch.h>
#include <terrain/genesis_delta.h>

#include <xxhash.h>

#include <algorithm>
#include <array>
#include <string>

namespace terrain {
namespace {

constexpr std::uint8_t kMagic[4] = {'T', 'R', 'G', 'D'};
constexpr int kLast = bspline::kControls - 1;
constexpr std::size_t kTileSamples = std::size_t{kTileVertices} * kTileVertices;

Error truncated(const char* what) {
    return makeError(
        ErrorCode::kTruncated,
        std::string("genesis delta truncated (or a number not in its shortest form) in ") + what);
}

// Catmull-Rom weights at t = a / 6 (a = 0..6), times 432 (2 * 6^3): integers, so the
// prediction below is exact integer arithmetic on both sides.
constexpr std::array<std::int64_t, 4> catmullRom432(std::int64_t a) {
    return {
        -36 * a + 12 * a * a - a * a * a, 432 - 30 * a * a + 3 * a * a * a,
        36 * a + 24 * a * a - 3 * a * a * a, -6 * a * a + a * a * a};
}

/// Catmull-Rom weights at the five Greville points (a = 0, 1, 3, 5, 6). At the ends the surface
/// is the sample itself ({0, 432, 0, 0} and {0, 0, 432, 0}), so those take no products.
constexpr std::array<std::array<std::int64_t, 4>, bspline::kControls> kGrevilleWeights = {
    catmullRom432(bspline::kGrevilleSixths[0]), catmullRom432(bspline::kGrevilleSixths[1]),
    catmullRom432(bspline::kGrevilleSixths[2]), catmullRom432(bspline::kGrevilleSixths[3]),
    catmullRom432(bspline::kGrevilleSixths[4])};
static_assert(kGrevilleWeights[0] == std::array<std::int64_t, 4>{0, 432, 0, 0});
static_assert(kGrevilleWeights[4] == std::array<std::int64_t, 4>{0, 0, 432, 0});

/// bspline::kInterpolation times v (rows 0 and 4 are unit rows times 120; the zeros are skipped,
/// every other product is the same, so the sums are exactly the full product's).
constexpr std::array<std::int64_t, bspline::kControls>
interpolate(std::int64_t v0, std::int64_t v1, std::int64_t v2, std::int64_t v3, std::int64_t v4) {
    constexpr auto& k = bspline::kInterpolation;
    static_assert(k[0][0] == 120 && k[0][1] == 0 && k[0][2] == 0 && k[0][3] == 0 && k[0][4] == 0);
    static_assert(k[4][0] == 0 && k[4][1] == 0 && k[4][2] == 0 && k[4][3] == 0 && k[4][4] == 120);
    return {
        k[0][0] * v0, k[1][0] * v0 + k[1][1] * v1 + k[1][2] * v2 + k[1][3] * v3 + k[1][4] * v4,
        k[2][0] * v0 + k[2][1] * v1 + k[2][2] * v2 + k[2][3] * v3 + k[2][4] * v4,
        k[3][0] * v0 + k[3][1] * v1 + k[3][2] * v2 + k[3][3] * v3 + k[3][4] * v4, k[4][4] * v4};
}

/// What a patch's controls are coded against: the controls that make the spline interpolate the
/// Catmull-Rom surface through the 4 x 4 samples around the cell (clamped to the grid) at the
/// Greville points, as ops make patches interpolate their craters there. A crater's patch
/// follows the samples it was made with, so the residual is its detail beyond that smooth
/// surface. Integer arithmetic throughout (heights in 1/48 quanta, as deformation.cpp), so both
/// sides predict the same numbers. Every patch of a join goes through here twice (encode and
/// decode): products by 0 and 1 are left out.
std::array<std::int64_t, kPatchControls>
predictControls(const Terrain& t, std::int32_t cx, std::int32_t cy) {
    constexpr int n = bspline::kControls;
    const std::int32_t last_x = t.spec().paddedWidth() - 1;
    const std::int32_t last_y = t.spec().paddedHeight() - 1;
    std::array<std::array<std::int64_t, 4>, 4> s{};
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i)
            s[static_cast<std::size_t>(j)][static_cast<std::size_t>(i)] =
                t.sample(std::clamp(cx - 1 + i, 0, last_x), std::clamp(cy - 1 + j, 0, last_y));
    // the surface at the Greville points, 1/48 quanta: 432 * the samples interpolated in v
    // (column), then in u, one rounding
    std::array<std::int64_t, kPatchControls> h48{};
    for (std::size_t j = 0; j < static_cast<std::size_t>(n); ++j) {
        std::array<std::int64_t, 4> column{};
        if (j == 0 || j == static_cast<std::size_t>(n) - 1) {
            const std::size_t row = j == 0 ? 1 : 2;
            for (std::size_t i = 0; i < 4; ++i)
                column[i] = 432 * s[row][i];
        } else {
            const auto& wv = kGrevilleWeights[j];
            for (std::size_t i = 0; i < 4; ++i)
                column[i] = wv[0] * s[0][i] + wv[1] * s[1][i] + wv[2] * s[2][i] + wv[3] * s[3][i];
        }
        std::int64_t* h = &h48[j * static_cast<std::size_t>(n)];
        h[0] = roundDiv(48 * 432 * column[1], 432 * 432);
        h[n - 1] = roundDiv(48 * 432 * column[2], 432 * 432);
        for (std::size_t i = 1; i + 1 < static_cast<std::size_t>(n); ++i) {
            const auto& wu = kGrevilleWeights[i];
            const std::int64_t sum =
                wu[0] * column[0] + wu[1] * column[1] + wu[2] * column[2] + wu[3] * column[3];
            h[i] = roundDiv(48 * sum, 432 * 432);
        }
    }
    // interpolated in u, then in v (every product below 2^53), one rounding
    std::array<std::int64_t, kPatchControls> rows{};
    for (std::size_t j = 0; j < static_cast<std::size_t>(n); ++j) {
        const std::int64_t* h = &h48[j * static_cast<std::size_t>(n)];
        const auto r = interpolate(h[0], h[1], h[2], h[3], h[4]);
        std::copy(r.begin(), r.end(), rows.begin() + static_cast<std::ptrdiff_t>(j) * n);
    }
    std::array<std::int64_t, kPatchControls> out{};
    constexpr std::int64_t kDivisor =
        bspline::kInterpolationScale * bspline::kInterpolationScale * (48 / kControlScale);
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) {
        const auto c =
            interpolate(rows[i], rows[n + i], rows[2 * n + i], rows[3 * n + i], rows[4 * n + i]);
        for (std::size_t j = 0; j < static_cast<std::size_t>(n); ++j)
            out[j * static_cast<std::size_t>(n) + i] = roundDiv(c[j], kDivisor);
    }
    return out;
}

/// The borders in the order of Neighbours: below, above, left, right.
constexpr Edge kSides[4] = {Edge::kMinV, Edge::kMaxV, Edge::kMinU, Edge::kMaxU};

/// How a control of a patch is known to the receiver.
enum class ControlSource : std::uint8_t {
    kSent,     ///< residual from predictControls()
    kCorner,   ///< pinned to the base corner sample
    kStraight, ///< border facing a base cell: on the straight base edge
    kBelow,    ///< row j = 0 facing a patch below: that patch's row j = 4
    kLeft,     ///< column i = 0 facing a patch to the left: that patch's column i = 4
};

/// Which patched neighbours a cell has (map edges have none and are sent).
struct Neighbours {
    bool in_map[4] = {false, false, false, false}; ///< below, above, left, right
    bool patched[4] = {false, false, false, false};
};

ControlSource sourceOf(int i, int j, const Neighbours& n) {
    if ((i == 0 || i == kLast) && (j == 0 || j == kLast))
        return ControlSource::kCorner;
    // the borders, in the order below, above, left, right (no control is on two: corners)
    const int side = j == 0 ? 0 : j == kLast ? 1 : i == 0 ? 2 : i == kLast ? 3 : -1;
    if (side < 0 || !n.in_map[side])
        return ControlSource::kSent;
    if (!n.patched[side])
        return ControlSource::kStraight;
    if (side == 0)
        return ControlSource::kBelow;
    if (side == 2)
        return ControlSource::kLeft;
    return ControlSource::kSent; // shared with a patch above or to the right: sent here once
}

DetailPatch* findIn(std::vector<PatchEntry>& patches, std::uint16_t cell) {
    const auto it = std::lower_bound(
        patches.begin(), patches.end(), cell,
        [](const PatchEntry& e, std::uint16_t c) { return e.cell < c; });
    return (it != patches.end() && it->cell == cell) ? &it->patch : nullptr;
}

template <typename HasPatch>
Neighbours neighboursOf(const WorldSpec& spec, std::int32_t cx, std::int32_t cy, HasPatch has) {
    Neighbours n;
    const std::int32_t nx[4] = {cx, cx, cx - 1, cx + 1};
    const std::int32_t ny[4] = {cy - 1, cy + 1, cy, cy};
    for (int k = 0; k < 4; ++k) {
        n.in_map[k] = nx[k] >= 0 && ny[k] >= 0 && nx[k] < spec.cellsX() && ny[k] < spec.cellsY();
        n.patched[k] = n.in_map[k] && has(nx[k], ny[k]);
    }
    return n;
}

} // namespace

std::vector<std::uint8_t>
encodeGenesisDelta(const Terrain& terrain, std::uint64_t sequence, std::uint64_t genesis_hash) {
    const WorldSpec& s = terrain.spec();
    std::vector<std::uint8_t> out(kMagic, kMagic + 4);
    detail::putU32(out, kGenesisDeltaVersion);
    for (std::int32_t v : {s.width, s.height, s.spacing, s.units_per_metre, s.patch_tolerance})
        detail::putI32(out, v);
    detail::putU64(out, sequence);
    detail::putU64(out, genesis_hash);
    std::vector<std::int32_t> tiles;
    for (std::int32_t tile = 0; tile < s.tileCount(); ++tile)
        if (terrain.differsFromGenesis(tile))
            tiles.push_back(tile);
    detail::putU32(out, static_cast<std::uint32_t>(tiles.size()));
    std::vector<std::uint8_t> record;
    std::vector<bool> local(static_cast<std::size_t>(kTileCells * kTileCells));
    std::int32_t previous_tile = -1;
    for (std::int32_t tile : tiles) {
        const std::int32_t tx = tile % s.tilesX();
        const std::int32_t ty = tile / s.tilesX();
        record.clear();
        for (std::int32_t y = 0; y < kTileVertices; ++y)
            for (std::int32_t x = 0; x < kTileVertices; ++x) {
                const std::int32_t vx = tx * kTileCells + x;
                const std::int32_t vy = ty * kTileCells + y;
                detail::putVarI32(record, terrain.sample(vx, vy) - terrain.original(vx, vy));
            }
        const std::span<const PatchEntry> patches = terrain.tilePatches(tile);
        detail::putVarU32(record, static_cast<std::uint32_t>(patches.size()));
        std::int32_t previous_cell = -1;
        for (const PatchEntry& e : patches) {
            detail::putVarU32(record, static_cast<std::uint32_t>(e.cell - previous_cell - 1));
            previous_cell = e.cell;
        }
        std::fill(local.begin(), local.end(), false);
        for (const PatchEntry& e : patches)
            local[e.cell] = true;
        const auto has = [&](std::int32_t x, std::int32_t y) {
            if (x / kTileCells == tx && y / kTileCells == ty)
                return static_cast<bool>(local[static_cast<std::size_t>(
                    (y % kTileCells) * kTileCells + x % kTileCells)]);
            return terrain.findPatch(x, y) != nullptr; // a border cell's neighbour
        };
        for (const PatchEntry& e : patches) {
            const std::int32_t cx = tx * kTileCells + e.cell % kTileCells;
            const std::int32_t cy = ty * kTileCells + e.cell / kTileCells;
            const Neighbours n = neighboursOf(s, cx, cy, has);
            const auto predicted = predictControls(terrain, cx, cy);
            for (int j = 0; j < bspline::kControls; ++j)
                for (int i = 0; i < bspline::kControls; ++i)
                    if (sourceOf(i, j, n) == ControlSource::kSent)
                        detail::putVarI32(
                            record,
                            static_cast<std::int32_t>(
                                e.patch.at(i, j) -
                                predicted[static_cast<std::size_t>(j * bspline::kControls + i)]));
        }
        detail::putVarU32(out, static_cast<std::uint32_t>(tile - previous_tile - 1));
        previous_tile = tile;
        detail::putVarU32(out, static_cast<std::uint32_t>(record.size()));
        out.insert(out.end(), record.begin(), record.end());
    }
    detail::putU64(out, terrain.worldHash());
    detail::putU64(out, XXH3_64bits(out.data(), out.size()));
    return out;
}

Result<DecodedSnapshot>
decodeGenesisDelta(std::span<const std::uint8_t> bytes, const Terrain& holder) {
    detail::ByteReader r(bytes);
    std::uint32_t magic = 0;
    if (!r.u32(magic))
        return truncated("the magic number");
    if (!std::equal(kMagic, kMagic + 4, bytes.begin()))
        return makeError(ErrorCode::kBadFormat, "not a genesis delta (magic is not TRGD)");
    std::uint32_t version = 0;
    if (!r.u32(version))
        return truncated("the version");
    if (version != kGenesisDeltaVersion)
        return makeError(
            ErrorCode::kUnsupported, "genesis delta version " + std::to_string(version) +
                                         " is not supported (this build reads version " +
                                         std::to_string(kGenesisDeltaVersion) + ")");
    WorldSpec spec;
    std::uint64_t sequence = 0;
    std::uint64_t genesis_hash = 0;
    std::uint32_t tile_count = 0;
    if (!r.i32(spec.width) || !r.i32(spec.height) || !r.i32(spec.spacing) ||
        !r.i32(spec.units_per_metre) || !r.i32(spec.patch_tolerance) || !r.u64(sequence) ||
        !r.u64(genesis_hash) || !r.u32(tile_count))
        return truncated("the header");
    if (!(spec == holder.spec()))
        return makeError(
            ErrorCode::kSizeMismatch, "the genesis delta is for another world's spec (" +
                                          std::to_string(spec.width) + " x " +
                                          std::to_string(spec.height) + ")");
    if (genesis_hash != holder.genesisHash())
        return makeError(
            ErrorCode::kHashMismatch,
            "the genesis held here differs from the one the delta was made on");
    if (tile_count > static_cast<std::uint32_t>(spec.tileCount()))
        return makeError(
            ErrorCode::kOutOfRange, "tile count " + std::to_string(tile_count) + " exceeds the " +
                                        std::to_string(spec.tileCount()) + " tiles of the map");

    // the genesis: samples back on the original ground, no patches, hashed at the end
    Terrain t;
    t.spec_ = spec;
    t.padded_width_ = holder.padded_width_;
    t.samples_ = *holder.original_;
    t.original_ = holder.original_;
    t.tiles_.resize(holder.tiles_.size());

    const std::size_t pw = static_cast<std::size_t>(t.padded_width_);
    // pass 1: every record's displacements and patch cells (a patch's prediction reads samples
    // around its cell, and its borders depend on patches in later tiles); pass 2: the controls
    struct Pending {
        std::int32_t tile = 0;
        detail::ByteReader controls{std::span<const std::uint8_t>{}};
    };
    std::vector<Pending> pending;
    pending.reserve(tile_count);
    // vertices written by a record; a shared edge vertex must be the same in every record
    std::vector<std::uint8_t> written(t.samples_.size(), 0);
    std::int64_t previous_tile = -1;
    for (std::uint32_t n = 0; n < tile_count; ++n) {
        std::uint32_t gap = 0;
        std::uint32_t length = 0;
        if (!r.varU32(gap) || !r.varU32(length))
            return truncated("a tile header");
        const std::int64_t tile = previous_tile + 1 + gap;
        if (tile >= spec.tileCount())
            return makeError(
                ErrorCode::kOutOfRange, "tile " + std::to_string(tile) + " is beyond the map's " +
                                            std::to_string(spec.tileCount()) +
                                            " tiles (or tiles are out of order)");
        previous_tile = tile;
        if (length > r.remaining())
            return truncated("a tile record");
        detail::ByteReader rec(bytes.subspan(r.position(), length));
        r.skip(length);
        const auto tile32 = static_cast<std::int32_t>(tile);
        const std::int32_t tx = tile32 % spec.tilesX();
        const std::int32_t ty = tile32 / spec.tilesX();
        for (std::int32_t y = 0; y < kTileVertices; ++y)
            for (std::int32_t x = 0; x < kTileVertices; ++x) {
                std::int32_t displacement = 0;
                if (!rec.varI32(displacement))
                    return makeError(
                        ErrorCode::kTruncated, "genesis delta tile " + std::to_string(tile) +
                                                   " truncated (or overlong) in its displacements");
                const std::size_t at = static_cast<std::size_t>(ty * kTileCells + y) * pw +
                                       static_cast<std::size_t>(tx * kTileCells + x);
                const std::int64_t v = std::int64_t{(*t.original_)[at]} + displacement;
                if (v > kMaxHeightQuanta || v < -kMaxHeightQuanta)
                    return makeError(
                        ErrorCode::kOutOfRange, "sample " + std::to_string(v) +
                                                    " is beyond the height limit in tile " +
                                                    std::to_string(tile));
                if (written[at] != 0 && t.samples_[at] != static_cast<std::int32_t>(v))
                    return makeError(
                        ErrorCode::kInvariantBroken, "tiles disagree on the shared edge vertex (" +
                                                         std::to_string(tx * kTileCells + x) +
                                                         ", " +
                                                         std::to_string(ty * kTileCells + y) + ")");
                t.samples_[at] = static_cast<std::int32_t>(v);
                written[at] = 1;
            }
        std::uint32_t count = 0;
        if (!rec.varU32(count))
            return truncated("a patch count");
        if (count > static_cast<std::uint32_t>(kTileCells * kTileCells))
            return makeError(
                ErrorCode::kOutOfRange,
                "patch count " + std::to_string(count) + " exceeds the cells of a tile");
        std::vector<PatchEntry>& patches = t.mutablePatches(static_cast<std::size_t>(tile));
        patches.resize(count);
        std::int64_t previous_cell = -1;
        for (PatchEntry& e : patches) {
            std::uint32_t cell_gap = 0;
            if (!rec.varU32(cell_gap))
                return truncated("a patch cell");
            const std::int64_t cell = previous_cell + 1 + cell_gap;
            const std::int64_t cx = tx * kTileCells + cell % kTileCells;
            const std::int64_t cy = ty * kTileCells + cell / kTileCells;
            if (cell >= kTileCells * kTileCells || cx >= spec.cellsX() || cy >= spec.cellsY())
                return makeError(
                    ErrorCode::kOutOfRange, "patch cell " + std::to_string(cell) + " of tile " +
                                                std::to_string(tile) + " is outside the map");
            previous_cell = cell;
            e.cell = static_cast<std::uint16_t>(cell);
        }
        pending.push_back(Pending{tile32, rec});
    }
    // a tile's own patches through a table (binary searches were most of this pass), its
    // neighbours' by search: only border cells ask for those
    std::vector<const DetailPatch*> local(static_cast<std::size_t>(kTileCells * kTileCells));
    for (Pending& p : pending) {
        const std::int32_t tx = p.tile % spec.tilesX();
        const std::int32_t ty = p.tile / spec.tilesX();
        std::vector<PatchEntry>& own = t.mutablePatches(static_cast<std::size_t>(p.tile));
        std::fill(local.begin(), local.end(), nullptr);
        for (const PatchEntry& e : own)
            local[e.cell] = &e.patch;
        const auto at = [&](std::int32_t x, std::int32_t y) -> const DetailPatch* {
            if (x / kTileCells == tx && y / kTileCells == ty)
                return local[Terrain::localCell(x, y)];
            return findIn(
                *t.tiles_[static_cast<std::size_t>(t.tileOfCell(x, y))].patches,
                Terrain::localCell(x, y));
        };
        const auto has = [&](std::int32_t x, std::int32_t y) { return at(x, y) != nullptr; };
        for (PatchEntry& e : own) {
            const std::int32_t cx = tx * kTileCells + e.cell % kTileCells;
            const std::int32_t cy = ty * kTileCells + e.cell / kTileCells;
            const Neighbours n = neighboursOf(spec, cx, cy, has);
            const CellCorners corners = t.corners(cx, cy);
            // earlier in the order, so their controls are decoded already
            const DetailPatch* below = n.patched[0] ? at(cx, cy - 1) : nullptr;
            const DetailPatch* left = n.patched[2] ? at(cx - 1, cy) : nullptr;
            DetailPatch& patch = e.patch;
            pinCorners(patch, corners);
            for (int side = 0; side < 4; ++side)
                if (n.in_map[side] && !n.patched[side])
                    straightenEdge(patch, kSides[side], corners);
            const auto predicted = predictControls(t, cx, cy);
            for (int j = 0; j < bspline::kControls; ++j)
                for (int i = 0; i < bspline::kControls; ++i) {
                    std::int64_t c = patch.at(i, j);
                    switch (sourceOf(i, j, n)) {
                    case ControlSource::kCorner:
                    case ControlSource::kStraight:
                        break;
                    case ControlSource::kBelow:
                        c = below->at(i, kLast);
                        break;
                    case ControlSource::kLeft:
                        c = left->at(kLast, j);
                        break;
                    case ControlSource::kSent: {
                        std::int32_t residual = 0;
                        if (!p.controls.varI32(residual))
                            return truncated("patch controls");
                        c = predicted[static_cast<std::size_t>(j * bspline::kControls + i)] +
                            residual;
                        break;
                    }
                    }
                    if (c > kControlScale * kMaxHeightQuanta ||
                        c < -kControlScale * kMaxHeightQuanta)
                        return makeError(
                            ErrorCode::kOutOfRange,
                            "patch control beyond the height limit in tile " +
                                std::to_string(p.tile));
                    patch.at(i, j) = static_cast<std::int32_t>(c);
                }
        }
        if (p.controls.remaining() != 0)
            return makeError(
                ErrorCode::kBadFormat,
                "genesis delta tile " + std::to_string(p.tile) + " has trailing bytes");
    }
    std::uint64_t world_hash = 0;
    if (!r.u64(world_hash))
        return truncated("the world hash");
    const std::size_t checked = r.position();
    std::uint64_t checksum = 0;
    if (!r.u64(checksum))
        return truncated("the checksum");
    if (r.remaining() != 0)
        return makeError(ErrorCode::kBadFormat, "genesis delta has trailing bytes");
    if (checksum != XXH3_64bits(bytes.data(), checked))
        return makeError(
            ErrorCode::kHashMismatch, "genesis delta checksum differs: the bytes are corrupt");

    // one encoding per world: the entries are exactly the tiles that differ from the genesis
    std::vector<std::uint8_t> in_delta(static_cast<std::size_t>(spec.tileCount()), 0);
    for (const Pending& p : pending)
        in_delta[static_cast<std::size_t>(p.tile)] = 1;
    for (std::int32_t tile = 0; tile < spec.tileCount(); ++tile) {
        if (t.differsFromGenesis(tile) != (in_delta[static_cast<std::size_t>(tile)] != 0))
            return makeError(
                ErrorCode::kBadFormat,
                "tile " + std::to_string(tile) +
                    (in_delta[static_cast<std::size_t>(tile)] != 0
                         ? " is in the genesis delta but equals its genesis"
                         : " differs from its genesis but is not in the genesis delta"));
        t.patch_count_ += t.tiles_[static_cast<std::size_t>(tile)].patches->size();
        t.refreshTile(tile);
    }
    t.rehashWorld();
    if (auto status = t.checkInvariants(); !status)
        return status.error();
    if (t.worldHash() != world_hash)
        return makeError(
            ErrorCode::kHashMismatch,
            "world hash of the decoded state differs from the genesis delta's");
    return DecodedSnapshot{std::move(t), sequence};
}

std::uint64_t maxGenesisDeltaBytes(const WorldSpec& spec) {
    constexpr std::uint64_t kHeader = 4 + 4 + 5 * 4 + 8 + 8 + 4;
    constexpr std::uint64_t kPatch = 5 + 5 * (kPatchControls - 4);
    constexpr std::uint64_t kRecord = 5 * kTileSamples + 5 + kTileCells * kTileCells * kPatch;
    return kHeader + static_cast<std::uint64_t>(spec.tileCount()) * (5 + 5 + kRecord) + 16;
}

} // namespace terrain
