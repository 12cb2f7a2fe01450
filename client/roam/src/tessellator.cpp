#include <terrain/fixed_point.h>
#include <terrain/roam/tessellator.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain::roam {

namespace {

constexpr std::int32_t kBaseVertices = kTileVertices * kTileVertices;
constexpr std::uint32_t kDiamondsPerBlock = kLatticePerCell * kLatticePerCell;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

float roundUp(double v) {
    float f = static_cast<float>(v);
    if (static_cast<double>(f) < v)
        f = std::nextafter(f, std::numeric_limits<float>::infinity());
    return f;
}

float roundDown(double v) {
    float f = static_cast<float>(v);
    if (static_cast<double>(f) > v)
        f = std::nextafter(f, -std::numeric_limits<float>::infinity());
    return f;
}

/// Local positions (l * 16 + k) of the sub-cell diamonds of each level inside one cell; the
/// level depends only on the position within the cell (cell origins are multiples of 16).
const std::array<std::vector<std::uint8_t>, kFinestTriangleLevel>& localPositionsByLevel() {
    static const auto table = [] {
        std::array<std::vector<std::uint8_t>, kFinestTriangleLevel> t;
        for (std::int32_t l = 0; l < kLatticePerCell; ++l)
            for (std::int32_t k = 0; k < kLatticePerCell; ++k) {
                if (k == 0 && l == 0)
                    continue;
                const Diamond d = diamondAt({k, l});
                t[static_cast<std::size_t>(d.level)].push_back(
                    static_cast<std::uint8_t>(l * kLatticePerCell + k));
            }
        return t;
    }();
    return table;
}

std::int32_t halfOfLevel(int level) {
    const int t = level % 2 == 0 ? (18 - level) / 2 : (19 - level) / 2;
    return 1 << t;
}

std::int32_t reachOfLevel(int level) {
    return (level % 2 == 0 ? 3 : 2) * halfOfLevel(level);
}

} // namespace

Tessellator::Tessellator(const Terrain& terrain, const TessellatorOptions& options)
    : terrain_(&terrain), options_(options) {
    terrainChanged({}, true);
}

void Tessellator::adoptSpec() {
    spec_ = terrain_->spec();
    metres_per_lattice_ = spec_.spacingMetres() / kLatticePerCell;
    metres_per_fine_ = spec_.metresPerUnit() / static_cast<double>(kFineUnitsPerQuantum);
    grid_w_ = spec_.paddedWidth();
    grid_h_ = spec_.paddedHeight();
    max_x_ = (grid_w_ - 1) * kLatticePerCell;
    max_y_ = (grid_h_ - 1) * kLatticePerCell;
    real_x_ = spec_.cellsX() * kLatticePerCell;
    real_y_ = spec_.cellsY() * kLatticePerCell;
    grid_count_ = static_cast<std::uint32_t>(grid_w_) * static_cast<std::uint32_t>(grid_h_);
    const std::size_t tiles = idx(spec_.tileCount());
    tiles_.clear();
    tiles_.resize(tiles);
    tile_visible_.assign(tiles, 0);
    vertex_version_.assign(tiles, 0);
    tile_blocks_.clear();
    tile_blocks_.resize(tiles);
    delta_.clear();
    zlo_.clear();
    zhi_.clear();
    state_.clear();
    heap_pos_.clear();
    block_local_.clear();
    heap_.clear();
}

// ---- ids and heights ----------------------------------------------------------------------

Tessellator::DiamondId Tessellator::idOf(LatticePoint p) const {
    if (!insideMap(p))
        return kNoDiamond;
    if (isGridVertex(p))
        return static_cast<DiamondId>(p.y / kLatticePerCell) * static_cast<DiamondId>(grid_w_) +
               static_cast<DiamondId>(p.x / kLatticePerCell);
    const std::int32_t block = blocks_.blockOf(p.x / kLatticePerCell, p.y / kLatticePerCell);
    if (block < 0)
        return kNoDiamond;
    return grid_count_ + static_cast<DiamondId>(block) * kDiamondsPerBlock +
           static_cast<DiamondId>(
               (p.y % kLatticePerCell) * kLatticePerCell + p.x % kLatticePerCell);
}

LatticePoint Tessellator::pointOf(DiamondId id) const {
    if (id < grid_count_) {
        const auto w = static_cast<DiamondId>(grid_w_);
        return {
            static_cast<std::int32_t>(id % w) * kLatticePerCell,
            static_cast<std::int32_t>(id / w) * kLatticePerCell};
    }
    const DiamondId r = id - grid_count_;
    const auto block = static_cast<std::int32_t>(r / kDiamondsPerBlock);
    const auto local = static_cast<std::int32_t>(r % kDiamondsPerBlock);
    const DetailBlocks::CellXY c = blocks_.cellOf(block);
    return {
        c.x * kLatticePerCell + local % kLatticePerCell,
        c.y * kLatticePerCell + local / kLatticePerCell};
}

std::int64_t Tessellator::heightAt(LatticePoint p) const {
    if (isGridVertex(p))
        return static_cast<std::int64_t>(
                   terrain_->sample(p.x / kLatticePerCell, p.y / kLatticePerCell)) *
               kFineUnitsPerQuantum;
    std::int32_t cx = p.x / kLatticePerCell;
    std::int32_t cy = p.y / kLatticePerCell;
    std::int32_t k = p.x % kLatticePerCell;
    std::int32_t l = p.y % kLatticePerCell;
    if (const std::int32_t b = blocks_.blockOf(cx, cy); b >= 0)
        return blocks_.height(b, k, l);
    if (k == 0)
        if (const std::int32_t b = blocks_.blockOf(cx - 1, cy); b >= 0)
            return blocks_.height(b, kLatticePerCell, l);
    if (l == 0)
        if (const std::int32_t b = blocks_.blockOf(cx, cy - 1); b >= 0)
            return blocks_.height(b, k, kLatticePerCell);
    // a cell without a block: the base triangles, exact in fine units
    if (cx >= blocks_.cellsX()) {
        cx -= 1;
        k += kLatticePerCell;
    }
    if (cy >= blocks_.cellsY()) {
        cy -= 1;
        l += kLatticePerCell;
    }
    return baseHeightScaled(terrain_->corners(cx, cy), cellDiagonal(cx, cy), k, l, kLatticePerCell);
}

void Tessellator::resizeDiamondState() {
    const std::size_t n =
        grid_count_ + static_cast<std::size_t>(blocks_.capacity()) * kDiamondsPerBlock;
    delta_.resize(n, 0.0f);
    zlo_.resize(n, 0.0f);
    zhi_.resize(n, 0.0f);
    state_.resize(n, 0);
    heap_pos_.resize(n, -1);
    block_local_.resize(idx(blocks_.capacity()), -1);
}

// ---- error bounds -------------------------------------------------------------------------

double Tessellator::childBounds(LatticePoint c, double& zlo, double& zhi) const {
    const DiamondId id = idOf(c);
    if (id != kNoDiamond) {
        zlo = std::min(zlo, static_cast<double>(zlo_[id]));
        zhi = std::max(zhi, static_cast<double>(zhi_[id]));
        return delta_[id];
    }
    // a cell without a block is drawn with its base triangles, which are the true surface
    const Diamond d = diamondAt(c);
    for (const LatticePoint corner : hypotenuseEnds(d)) {
        const double z = static_cast<double>(heightAt(corner)) * metres_per_fine_;
        zlo = std::min(zlo, z);
        zhi = std::max(zhi, z);
    }
    for (const LatticePoint corner : apexes(d))
        if (insideMap(corner)) {
            const double z = static_cast<double>(heightAt(corner)) * metres_per_fine_;
            zlo = std::min(zlo, z);
            zhi = std::max(zhi, z);
        }
    return 0.0;
}

void Tessellator::computeBounds(const Diamond& d, DiamondId id) {
    const auto ends = hypotenuseEnds(d);
    const std::int64_t zc = heightAt(d.centre);
    const std::int64_t z0 = heightAt(ends[0]);
    const std::int64_t z1 = heightAt(ends[1]);
    std::int64_t own_lo = std::min({zc, z0, z1});
    std::int64_t own_hi = std::max({zc, z0, z1});
    for (const LatticePoint a : apexes(d))
        if (insideMap(a)) {
            const std::int64_t z = heightAt(a);
            own_lo = std::min(own_lo, z);
            own_hi = std::max(own_hi, z);
        }
    // how far the centre is from the hypotenuse the unsplit triangles interpolate
    const double local = static_cast<double>(std::llabs(2 * zc - z0 - z1)) * 0.5 * metres_per_fine_;
    double child = 0.0;
    double lo = kInfinity;
    double hi = -kInfinity;
    if (d.level == kMaxDiamondLevel) {
        for (const LatticePoint a : apexes(d)) {
            if (!insideMap(a))
                continue;
            const LatticePoint c3 = centroidTimes3(triangleOf(d, a));
            const std::int32_t block =
                blocks_.blockOf(c3.x / (3 * kLatticePerCell), c3.y / (3 * kLatticePerCell));
            if (block >= 0)
                child = std::max(
                    child, static_cast<double>(blocks_.finestError(block)) * metres_per_fine_);
        }
    } else {
        std::array<LatticePoint, 4> kids{};
        const int n = children(d, kids);
        for (int i = 0; i < n; ++i)
            if (insideMap(kids[idx(i)]))
                child = std::max(child, childBounds(kids[idx(i)], lo, hi));
    }
    const double delta = local + child;
    delta_[id] = roundUp(delta);
    zlo_[id] = roundDown(std::min(static_cast<double>(own_lo) * metres_per_fine_ - delta, lo));
    zhi_[id] = roundUp(std::max(static_cast<double>(own_hi) * metres_per_fine_ + delta, hi));
}

void Tessellator::recomputeBounds(
    std::int32_t lx0, std::int32_t ly0, std::int32_t lx1, std::int32_t ly1) {
    const auto& positions = localPositionsByLevel();
    const bool whole = lx0 <= 0 && ly0 <= 0 && lx1 >= max_x_ && ly1 >= max_y_;
    for (int level = kMaxDiamondLevel; level >= kCellTriangleLevel; --level) {
        const std::int32_t reach = reachOfLevel(level) + kLatticePerCell;
        const std::int32_t cx0 = std::max(0, (lx0 - reach) / kLatticePerCell);
        const std::int32_t cy0 = std::max(0, (ly0 - reach) / kLatticePerCell);
        const std::int32_t cx1 = std::min(blocks_.cellsX() - 1, (lx1 + reach) / kLatticePerCell);
        const std::int32_t cy1 = std::min(blocks_.cellsY() - 1, (ly1 + reach) / kLatticePerCell);
        auto visit_block = [&](std::int32_t block) {
            const DetailBlocks::CellXY c = blocks_.cellOf(block);
            for (const std::uint8_t local : positions[idx(level)]) {
                const LatticePoint p{
                    c.x * kLatticePerCell + local % kLatticePerCell,
                    c.y * kLatticePerCell + local / kLatticePerCell};
                const DiamondId id =
                    grid_count_ + static_cast<DiamondId>(block) * kDiamondsPerBlock + local;
                computeBounds(diamondAt(p), id);
                if (!whole)
                    recomputed_.push_back(id);
            }
        };
        if (whole) {
            for (std::int32_t b = 0; b < blocks_.capacity(); ++b)
                if (blocks_.inUse(b))
                    visit_block(b);
        } else {
            for (std::int32_t cy = cy0; cy <= cy1; ++cy)
                for (std::int32_t cx = cx0; cx <= cx1; ++cx)
                    if (const std::int32_t b = blocks_.blockOf(cx, cy); b >= 0)
                        visit_block(b);
        }
    }
    for (int level = kCellTriangleLevel - 1; level >= 0; --level) {
        const std::int32_t h = halfOfLevel(level);
        const std::int32_t reach = reachOfLevel(level);
        const std::int32_t x0 = std::max(0, (lx0 - reach) / h * h);
        const std::int32_t y0 = std::max(0, (ly0 - reach) / h * h);
        const std::int32_t x1 = std::min(max_x_, lx1 + reach);
        const std::int32_t y1 = std::min(max_y_, ly1 + reach);
        for (std::int32_t y = y0; y <= y1; y += h)
            for (std::int32_t x = x0; x <= x1; x += h) {
                const Diamond d = diamondAt({x, y});
                if (d.level != level)
                    continue;
                const DiamondId id = idOf(d.centre);
                computeBounds(d, id);
                if (!whole)
                    recomputed_.push_back(id);
            }
    }
}

Box Tessellator::boxOf(const Diamond& d, DiamondId id) const {
    const std::int32_t r = subtreeReach(d);
    // only the real map is drawn; padding contributes nothing
    const std::int32_t x0 = std::max(d.centre.x - r, 0);
    const std::int32_t y0 = std::max(d.centre.y - r, 0);
    const std::int32_t x1 = std::min(d.centre.x + r, real_x_);
    const std::int32_t y1 = std::min(d.centre.y + r, real_y_);
    Box b;
    b.lo = {x0 * metres_per_lattice_, y0 * metres_per_lattice_, zlo_[id]};
    b.hi = {x1 * metres_per_lattice_, y1 * metres_per_lattice_, zhi_[id]};
    if (x0 >= x1 || y0 >= y1)
        b.lo.x = b.hi.x + 1.0; // empty
    return b;
}

double Tessellator::priority(const ViewMetric& m, const Diamond& d, DiamondId id) const {
    const Box b = boxOf(d, id);
    if (b.lo.x > b.hi.x)
        return 0.0;
    return m.screenError(b, delta_[id]);
}

double Tessellator::deltaAt(LatticePoint p) const {
    const DiamondId id = idOf(p);
    if (id == kNoDiamond || !diamondAt(p).valid())
        return -1.0;
    return delta_[id];
}

// ---- the mesh -----------------------------------------------------------------------------

std::int32_t Tessellator::tileOf(const Triangle& t) const {
    const LatticePoint c3 = centroidTimes3(t);
    return (c3.y / (3 * kLatticePerTile)) * spec_.tilesX() + c3.x / (3 * kLatticePerTile);
}

bool Tessellator::emitted(const Triangle& t) const {
    const std::int32_t min_x = std::min({t.apex.x, t.left.x, t.right.x});
    const std::int32_t min_y = std::min({t.apex.y, t.left.y, t.right.y});
    return min_x < real_x_ && min_y < real_y_;
}

TileMesh::Indices Tessellator::indicesOf(const Triangle& t, std::int32_t tile) const {
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    TileMesh::Indices out{};
    const std::array<LatticePoint, 3> v = {t.apex, t.left, t.right};
    if (t.level <= kCellTriangleLevel) {
        for (std::size_t i = 0; i < 3; ++i)
            out[i] = static_cast<std::uint32_t>(
                (v[i].y / kLatticePerCell - ty * kTileCells) * kTileVertices +
                (v[i].x / kLatticePerCell - tx * kTileCells));
        return out;
    }
    const LatticePoint c3 = centroidTimes3(t);
    const std::int32_t cx = c3.x / (3 * kLatticePerCell);
    const std::int32_t cy = c3.y / (3 * kLatticePerCell);
    const std::int32_t block = blocks_.blockOf(cx, cy);
    const std::int32_t base = kBaseVertices + block_local_[idx(block)] * kBlockVertices;
    for (std::size_t i = 0; i < 3; ++i)
        out[i] = static_cast<std::uint32_t>(
            base + (v[i].y - cy * kLatticePerCell) * kBlockSide + (v[i].x - cx * kLatticePerCell));
    return out;
}

bool Tessellator::hasActiveChild(const Diamond& d) const {
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i)
        if (active(idOf(kids[idx(i)])))
            return true;
    return false;
}

bool Tessellator::canActivate(const Diamond& d, DiamondId id) const {
    if (id == kNoDiamond)
        return false;
    if (d.level == 0)
        return true;
    for (const LatticePoint a : apexes(d))
        if (insideMap(a) && !active(idOf(a)))
            return false;
    return true;
}

void Tessellator::splitTriangles(const Diamond& d, bool split, bool forced) {
    for (const LatticePoint a : apexes(d)) {
        if (!insideMap(a))
            continue;
        const Triangle t = triangleOf(d, a);
        const auto halves = splitTriangle(t);
        const std::int32_t tile = tileOf(t);
        TileMesh& mesh = tiles_[idx(tile)];
        if (split) {
            if (emitted(t))
                mesh.remove(triangleKey(t));
            for (const Triangle& h : halves)
                if (emitted(h))
                    mesh.add(triangleKey(h), indicesOf(h, tile));
            ++mesh.counters().splits;
            if (forced)
                ++mesh.counters().forced_splits;
        } else {
            // second half first, so the parent takes back the first half's slot (its own)
            if (emitted(halves[1]))
                mesh.remove(triangleKey(halves[1]));
            if (emitted(halves[0]))
                mesh.remove(triangleKey(halves[0]));
            if (emitted(t))
                mesh.add(triangleKey(t), indicesOf(t, tile));
            ++mesh.counters().merges;
        }
    }
}

std::int64_t Tessellator::splitGain(const Diamond& d) const {
    std::int64_t gain = 0;
    for (const LatticePoint a : apexes(d)) {
        if (!insideMap(a))
            continue;
        const Triangle t = triangleOf(d, a);
        const auto halves = splitTriangle(t);
        gain += (emitted(halves[0]) ? 1 : 0) + (emitted(halves[1]) ? 1 : 0) - (emitted(t) ? 1 : 0);
    }
    return gain;
}

bool Tessellator::activate(const Diamond& d, DiamondId id, bool forced, FrameStats& stats) {
    if (active(id))
        return true;
    if (d.level > 0) {
        for (const LatticePoint a : apexes(d)) {
            if (!insideMap(a))
                continue;
            const DiamondId parent = idOf(a);
            if (parent == kNoDiamond) {
                ++missing_block_refusals_;
                return false;
            }
            if (!active(parent) && !activate(diamondAt(a), parent, true, stats))
                return false;
        }
    }
    const std::int64_t gain = splitGain(d);
    if (triangles_ + gain > options_.max_triangles) {
        ++stats.refused_by_cap;
        refused_by_cap_ = true;
        return false;
    }
    state_[id] |= kActive;
    triangles_ += gain;
    ++stats.splits;
    if (forced)
        ++stats.forced_splits;
    if (!bookkeeping_)
        return true;
    splitTriangles(d, true, forced);
    clearCandidate(id);
    if (d.level > 0)
        for (const LatticePoint a : apexes(d))
            if (insideMap(a)) {
                const DiamondId parent = idOf(a);
                if ((state_[parent] & kMergeCandidate) != 0)
                    clearCandidate(parent);
            }
    setCandidate(id, kMergeCandidate);
    due_.push_back(id);
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i) {
        const LatticePoint c = kids[idx(i)];
        if (!insideMap(c))
            continue;
        const DiamondId child = idOf(c);
        if (child != kNoDiamond && !active(child) && canActivate(diamondAt(c), child)) {
            setCandidate(child, kSplitCandidate);
            due_.push_back(child);
        }
    }
    return true;
}

void Tessellator::deactivate(const Diamond& d, DiamondId id, FrameStats& stats) {
    state_[id] = static_cast<std::uint8_t>(state_[id] & ~kActive);
    triangles_ -= splitGain(d);
    ++stats.merges;
    if (!bookkeeping_)
        return;
    splitTriangles(d, false, false);
    clearCandidate(id);
    setCandidate(id, kSplitCandidate);
    due_.push_back(id);
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i) {
        const DiamondId child = idOf(kids[idx(i)]);
        if (child != kNoDiamond && (state_[child] & kSplitCandidate) != 0)
            clearCandidate(child);
    }
    if (d.level == 0)
        return;
    for (const LatticePoint a : apexes(d)) {
        if (!insideMap(a))
            continue;
        const DiamondId parent = idOf(a);
        const Diamond pd = diamondAt(a);
        if (active(parent) && !hasActiveChild(pd)) {
            setCandidate(parent, kMergeCandidate);
            due_.push_back(parent);
        }
    }
}

void Tessellator::deactivateSubtree(LatticePoint p, FrameStats& stats) {
    const DiamondId id = idOf(p);
    if (!active(id))
        return;
    const Diamond d = diamondAt(p);
    std::array<LatticePoint, 4> kids{};
    const int n = children(d, kids);
    for (int i = 0; i < n; ++i)
        if (insideMap(kids[idx(i)]))
            deactivateSubtree(kids[idx(i)], stats);
    deactivate(d, id, stats);
}

void Tessellator::emitTriangle(const Triangle& t, std::int32_t tile, TileMesh& mesh) {
    if (t.level < kFinestTriangleLevel && active(idOf(splitPoint(t)))) {
        const auto halves = splitTriangle(t);
        emitTriangle(halves[0], tile, mesh);
        emitTriangle(halves[1], tile, mesh);
        return;
    }
    if (emitted(t))
        mesh.add(triangleKey(t), indicesOf(t, tile));
}

Diamond Tessellator::tileRoot(std::int32_t tile) const {
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    return diamondAt(
        {tx * kLatticePerTile + kLatticePerTile / 2, ty * kLatticePerTile + kLatticePerTile / 2});
}

void Tessellator::emitTile(std::int32_t tile) {
    TileMesh& mesh = tiles_[idx(tile)];
    mesh.clear();
    const Diamond root = tileRoot(tile);
    for (const LatticePoint a : apexes(root))
        emitTriangle(triangleOf(root, a), tile, mesh);
}

void Tessellator::rebuildTileBlocks(std::int32_t tile) {
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    auto& list = tile_blocks_[idx(tile)];
    list.clear();
    for (std::int32_t cy = ty * kTileCells; cy < (ty + 1) * kTileCells; ++cy)
        for (std::int32_t cx = tx * kTileCells; cx < (tx + 1) * kTileCells; ++cx)
            if (const std::int32_t b = blocks_.blockOf(cx, cy); b >= 0) {
                block_local_[idx(b)] = static_cast<std::int32_t>(list.size());
                list.push_back(b);
            }
}

std::int32_t Tessellator::tileVertexCount(std::int32_t tile) const {
    return kBaseVertices +
           static_cast<std::int32_t>(tile_blocks_[idx(tile)].size()) * kBlockVertices;
}

TileVertex Tessellator::tileVertex(std::int32_t tile, std::uint32_t index) const {
    const std::int32_t tx = tile % spec_.tilesX();
    const std::int32_t ty = tile / spec_.tilesX();
    const auto i = static_cast<std::int32_t>(index);
    if (i < kBaseVertices) {
        const std::int32_t gx = tx * kTileCells + i % kTileVertices;
        const std::int32_t gy = ty * kTileCells + i / kTileVertices;
        return {
            {gx * kLatticePerCell, gy * kLatticePerCell},
            static_cast<std::int64_t>(terrain_->sample(gx, gy)) * kFineUnitsPerQuantum};
    }
    const std::int32_t r = i - kBaseVertices;
    const std::int32_t block = tile_blocks_[idx(tile)][idx(r / kBlockVertices)];
    const std::int32_t k = (r % kBlockVertices) % kBlockSide;
    const std::int32_t l = (r % kBlockVertices) / kBlockSide;
    const DetailBlocks::CellXY c = blocks_.cellOf(block);
    return {{c.x * kLatticePerCell + k, c.y * kLatticePerCell + l}, blocks_.height(block, k, l)};
}

// ---- terrain changes ----------------------------------------------------------------------

void Tessellator::terrainChanged(std::span<const CellRect> cells, bool all) {
    if (all) {
        // a snapshot may bring another world (size, spacing): start from its spec
        if (tiles_.empty() || !(terrain_->spec() == spec_))
            adoptSpec();
        blocks_.reset(*terrain_);
        resizeDiamondState();
        std::fill(state_.begin(), state_.end(), std::uint8_t{0});
        std::fill(heap_pos_.begin(), heap_pos_.end(), -1);
        heap_.clear();
        watched_.clear();
        due_.clear();
        for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
            rebuildTileBlocks(tile);
            ++vertex_version_[idx(tile)];
        }
        recomputeBounds(0, 0, max_x_, max_y_);
        needs_rebuild_ = true;
        return;
    }
    FrameStats ignored;
    for (const CellRect& r : cells) {
        if (r.empty())
            continue;
        // blocks about to go: coarsen everything that refines into them first
        removing_.clear();
        changed_tiles_.clear();
        auto note_block_cell = [&](DetailBlocks::CellXY c) {
            changed_tiles_.push_back((c.y / kTileCells) * spec_.tilesX() + c.x / kTileCells);
        };
        blocks_.plan(*terrain_, r, removing_);
        for (const std::int32_t block : removing_) {
            note_block_cell(blocks_.cellOf(block));
            const DetailBlocks::CellXY c = blocks_.cellOf(block);
            for (std::uint32_t local = 1; local < kDiamondsPerBlock; ++local)
                deactivateSubtree(
                    {c.x * kLatticePerCell + static_cast<std::int32_t>(local % kLatticePerCell),
                     c.y * kLatticePerCell + static_cast<std::int32_t>(local / kLatticePerCell)},
                    ignored);
            for (std::uint32_t local = 0; local < kDiamondsPerBlock; ++local) {
                const DiamondId id =
                    grid_count_ + static_cast<DiamondId>(block) * kDiamondsPerBlock + local;
                clearCandidate(id);
                state_[id] = 0;
            }
        }
        removed_.clear();
        added_.clear();
        blocks_.update(*terrain_, r, removed_, added_);
        resizeDiamondState();
        for (const std::int32_t block : added_)
            for (std::uint32_t local = 0; local < kDiamondsPerBlock; ++local) {
                const DiamondId id =
                    grid_count_ + static_cast<DiamondId>(block) * kDiamondsPerBlock + local;
                state_[id] = 0;
                heap_pos_[id] = -1;
            }
        // tiles whose block lists changed get new vertex arrays and a full index rewrite
        for (const std::int32_t block : added_)
            note_block_cell(blocks_.cellOf(block));
        std::sort(changed_tiles_.begin(), changed_tiles_.end());
        changed_tiles_.erase(
            std::unique(changed_tiles_.begin(), changed_tiles_.end()), changed_tiles_.end());
        for (const std::int32_t tile : changed_tiles_)
            rebuildTileBlocks(tile);
        // heights moved in these tiles
        for (std::int32_t ty = r.y0 / kTileCells;
             ty <= std::min(r.y1, blocks_.cellsY() - 1) / kTileCells; ++ty)
            for (std::int32_t tx = r.x0 / kTileCells;
                 tx <= std::min(r.x1, blocks_.cellsX() - 1) / kTileCells; ++tx)
                ++vertex_version_[idx(ty * spec_.tilesX() + tx)];
        recomputed_.clear();
        recomputeBounds(
            (r.x0 - 1) * kLatticePerCell, (r.y0 - 1) * kLatticePerCell,
            (r.x1 + 2) * kLatticePerCell, (r.y1 + 2) * kLatticePerCell);
        if (initialized_ && !needs_rebuild_) {
            for (const std::int32_t tile : changed_tiles_) {
                ++vertex_version_[idx(tile)];
                emitTile(tile);
            }
            for (const DiamondId id : recomputed_)
                refreshCandidate(id);
        }
    }
}

void Tessellator::refreshCandidate(DiamondId id) {
    const Diamond d = diamondAt(pointOf(id));
    std::uint8_t kind = 0;
    if (active(id))
        kind = hasActiveChild(d) ? 0 : kMergeCandidate;
    else if (canActivate(d, id))
        kind = kSplitCandidate;
    clearCandidate(id);
    if (kind != 0) {
        setCandidate(id, kind);
        due_.push_back(id);
    }
}

// ---- candidates ---------------------------------------------------------------------------

void Tessellator::setCandidate(DiamondId id, std::uint8_t kind) {
    state_[id] = static_cast<std::uint8_t>((state_[id] & kActive) | kind);
}

void Tessellator::clearCandidate(DiamondId id) {
    state_[id] = static_cast<std::uint8_t>(state_[id] & kActive);
    if (heap_pos_[id] >= 0)
        heapRemove(id);
}

void Tessellator::heapSiftUp(std::size_t i) {
    const HeapEntry e = heap_[i];
    while (i > 0) {
        const std::size_t parent = (i - 1) / 2;
        if (heap_[parent].key <= e.key)
            break;
        heap_[i] = heap_[parent];
        heap_pos_[heap_[i].id] = static_cast<std::int32_t>(i);
        i = parent;
    }
    heap_[i] = e;
    heap_pos_[e.id] = static_cast<std::int32_t>(i);
}

void Tessellator::heapSiftDown(std::size_t i) {
    const HeapEntry e = heap_[i];
    const std::size_t n = heap_.size();
    while (true) {
        std::size_t child = 2 * i + 1;
        if (child >= n)
            break;
        if (child + 1 < n && heap_[child + 1].key < heap_[child].key)
            ++child;
        if (e.key <= heap_[child].key)
            break;
        heap_[i] = heap_[child];
        heap_pos_[heap_[i].id] = static_cast<std::int32_t>(i);
        i = child;
    }
    heap_[i] = e;
    heap_pos_[e.id] = static_cast<std::int32_t>(i);
}

void Tessellator::heapPush(DiamondId id, double key) {
    if (heap_pos_[id] >= 0) {
        const auto i = static_cast<std::size_t>(heap_pos_[id]);
        heap_[i].key = key;
        heapSiftUp(i);
        heapSiftDown(static_cast<std::size_t>(heap_pos_[id]));
        return;
    }
    heap_.push_back({key, id});
    heapSiftUp(heap_.size() - 1);
}

void Tessellator::heapRemove(DiamondId id) {
    const auto i = static_cast<std::size_t>(heap_pos_[id]);
    heap_pos_[id] = -1;
    const HeapEntry last = heap_.back();
    heap_.pop_back();
    if (i == heap_.size())
        return;
    heap_[i] = last;
    heap_pos_[last.id] = static_cast<std::int32_t>(i);
    heapSiftUp(i);
    heapSiftDown(static_cast<std::size_t>(heap_pos_[last.id]));
}

void Tessellator::evaluate(const ViewMetric& m, DiamondId id, FrameStats& stats) {
    const std::uint8_t st = state_[id];
    if ((st & (kSplitCandidate | kMergeCandidate)) == 0)
        return;
    if (heap_pos_[id] >= 0)
        heapRemove(id);
    const Diamond d = diamondAt(pointOf(id));
    ++stats.evaluations;
    const Box box = boxOf(d, id);
    const double tau = options_.tau_pixels;
    if (box.lo.x > box.hi.x) {
        // wholly in the padding: never worth a triangle
        if ((st & kMergeCandidate) != 0)
            merges_.push_back({0.0, id});
        return;
    }
    const double delta = delta_[id];
    const double any = m.screenErrorAnyDirection(box, delta);
    const double p = any > tau && !m.intersectsFrustum(box) ? 0.0 : any;
    // distance at which the priority crosses tau; priorities depend on the eye position only
    const double threshold = m.errorScale() * delta / tau;
    const double distance = m.distanceTo(box);
    if ((st & kSplitCandidate) != 0) {
        if (p > tau) {
            splits_.push_back({p, id});
        } else if (any > tau) {
            state_[id] |= kWatched;
            watched_.push_back(id);
        } else if (threshold > m.camera().near_plane) {
            heapPush(id, travel_ + std::max(0.0, distance - threshold));
        }
        return;
    }
    if (p <= tau)
        merges_.push_back({p, id});
    else // due when the eye has moved away far enough, or far enough to take it out of view
        heapPush(id, travel_ + std::min(std::max(0.0, threshold - distance), m.exitSlack(box)));
}

void Tessellator::collectCandidates(const Triangle& t) {
    if (t.level >= kFinestTriangleLevel)
        return;
    const LatticePoint p = splitPoint(t);
    const DiamondId id = idOf(p);
    if (id == kNoDiamond)
        return;
    const Diamond d = diamondAt(p);
    if (active(id)) {
        if ((state_[id] & kMergeCandidate) == 0 && !hasActiveChild(d)) {
            setCandidate(id, kMergeCandidate);
            due_.push_back(id);
        }
        const auto halves = splitTriangle(t);
        collectCandidates(halves[0]);
        collectCandidates(halves[1]);
    } else if ((state_[id] & kSplitCandidate) == 0 && canActivate(d, id)) {
        setCandidate(id, kSplitCandidate);
        due_.push_back(id);
    }
}

// ---- frames -------------------------------------------------------------------------------

void Tessellator::refineTopDown(
    const ViewMetric& m, const Triangle& t, FrameStats& stats, bool& capped) {
    if (t.level >= kFinestTriangleLevel || capped)
        return;
    const LatticePoint p = splitPoint(t);
    const DiamondId id = idOf(p);
    if (id == kNoDiamond)
        return;
    if (!active(id)) {
        const Diamond d = diamondAt(p);
        ++stats.evaluations;
        if (priority(m, d, id) <= options_.tau_pixels)
            return;
        if (!activate(d, id, false, stats)) {
            capped = refused_by_cap_;
            return;
        }
    }
    const auto halves = splitTriangle(t);
    refineTopDown(m, halves[0], stats, capped);
    refineTopDown(m, halves[1], stats, capped);
}

void Tessellator::refineBestFirst(const ViewMetric& m, FrameStats& stats) {
    best_first_.clear();
    auto push = [&](const Triangle& t) {
        if (t.level >= kFinestTriangleLevel)
            return;
        const LatticePoint p = splitPoint(t);
        const DiamondId id = idOf(p);
        if (id == kNoDiamond)
            return;
        ++stats.evaluations;
        const double pr = active(id) ? kInfinity : priority(m, diamondAt(p), id);
        if (pr <= options_.tau_pixels)
            return;
        best_first_.push_back({pr, t});
        std::push_heap(best_first_.begin(), best_first_.end(), [](const auto& a, const auto& b) {
            return a.first < b.first;
        });
    };
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        const Diamond root = tileRoot(tile);
        for (const LatticePoint a : apexes(root))
            push(triangleOf(root, a));
    }
    while (!best_first_.empty()) {
        std::pop_heap(best_first_.begin(), best_first_.end(), [](const auto& a, const auto& b) {
            return a.first < b.first;
        });
        const Triangle t = best_first_.back().second;
        best_first_.pop_back();
        const LatticePoint p = splitPoint(t);
        const DiamondId id = idOf(p);
        if (!activate(diamondAt(p), id, false, stats)) {
            if (refused_by_cap_)
                break;
            continue;
        }
        const auto halves = splitTriangle(t);
        push(halves[0]);
        push(halves[1]);
    }
}

void Tessellator::rebuildTopDown(const ViewMetric& m, FrameStats& stats) {
    bookkeeping_ = false;
    std::fill(state_.begin(), state_.end(), std::uint8_t{0});
    for (const HeapEntry& e : heap_)
        heap_pos_[e.id] = -1;
    heap_.clear();
    watched_.clear();
    due_.clear();
    splits_.clear();
    merges_.clear();
    std::int64_t roots = 0;
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        const Diamond root = tileRoot(tile);
        for (const LatticePoint a : apexes(root))
            roots += emitted(triangleOf(root, a)) ? 1 : 0;
    }
    triangles_ = roots;
    refused_by_cap_ = false;
    bool capped = false;
    for (std::int32_t tile = 0; tile < tileCount() && !capped; ++tile) {
        const Diamond root = tileRoot(tile);
        for (const LatticePoint a : apexes(root))
            refineTopDown(m, triangleOf(root, a), stats, capped);
    }
    if (capped) {
        // the cap binds: spend the triangles where the error is largest, not where we began
        std::fill(state_.begin(), state_.end(), std::uint8_t{0});
        triangles_ = roots;
        refused_by_cap_ = false;
        refineBestFirst(m, stats);
    }
    for (std::int32_t tile = 0; tile < tileCount(); ++tile)
        emitTile(tile);
    bookkeeping_ = true;
    stats.rebuilt = true;
    if (options_.mode != TessellationMode::kSplitMerge)
        return;
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        const Diamond root = tileRoot(tile);
        for (const LatticePoint a : apexes(root))
            collectCandidates(triangleOf(root, a));
    }
    for (const DiamondId id : due_)
        evaluate(m, id, stats);
    due_.clear();
    // only a binding cap leaves work here; it waits for the next frame
    for (const Action& a : splits_)
        heapPush(a.id, travel_);
    for (const Action& a : merges_)
        heapPush(a.id, travel_);
    splits_.clear();
    merges_.clear();
}

void Tessellator::updateSplitMerge(const ViewMetric& m, FrameStats& stats) {
    // merge candidates kept split because they were in view: their keys cover the eye moving
    // them out of the frustum (exitSlack) but not the view turning, so after a turn of more
    // than cull_sweep_degrees every one is re-checked against the frustum
    const glm::dvec3 forward = glm::normalize(m.camera().forward);
    if (glm::dot(forward, sweep_forward_) <
        std::cos(options_.cull_sweep_degrees * 3.14159265358979323846 / 180.0)) {
        sweep_forward_ = forward;
        for (std::size_t i = 0; i < heap_.size(); ++i) {
            const HeapEntry e = heap_[i];
            if ((state_[e.id] & kMergeCandidate) == 0 || e.key <= travel_)
                continue;
            const Box box = boxOf(diamondAt(pointOf(e.id)), e.id);
            if (box.lo.x > box.hi.x || !m.intersectsFrustum(box))
                heapPush(e.id, travel_); // due now; moves the entry towards the root
        }
    }
    while (!heap_.empty() && heap_.front().key <= travel_) {
        const DiamondId id = heap_.front().id;
        heapRemove(id);
        due_.push_back(id);
    }
    watched_next_.swap(watched_);
    watched_.clear();
    for (const DiamondId id : watched_next_)
        if ((state_[id] & kWatched) != 0) {
            state_[id] = static_cast<std::uint8_t>(state_[id] & ~kWatched);
            due_.push_back(id);
        }
    const auto by_priority_up = [](const Action& a, const Action& b) {
        return a.priority < b.priority;
    };
    const auto by_priority_down = [](const Action& a, const Action& b) {
        return a.priority > b.priority;
    };
    deferred_.clear();
    while (!due_.empty()) {
        // evaluating appends to due_ only through splits and merges, which happen below
        evaluating_.swap(due_);
        due_.clear();
        for (const DiamondId id : evaluating_)
            evaluate(m, id, stats);
        evaluating_.clear();
        std::sort(merges_.begin(), merges_.end(), by_priority_up);
        for (const Action& a : merges_) {
            if ((state_[a.id] & kMergeCandidate) == 0 || !active(a.id))
                continue;
            if (stats.splits + stats.merges >= options_.work_budget) {
                deferred_.push_back(a.id);
                continue;
            }
            const Diamond d = diamondAt(pointOf(a.id));
            if (!hasActiveChild(d))
                deactivate(d, a.id, stats);
        }
        merges_.clear();
        std::sort(splits_.begin(), splits_.end(), by_priority_down);
        for (const Action& a : splits_) {
            if ((state_[a.id] & kSplitCandidate) == 0 || active(a.id))
                continue;
            if (stats.splits + stats.merges >= options_.work_budget) {
                deferred_.push_back(a.id);
                continue;
            }
            refused_by_cap_ = false;
            if (!activate(diamondAt(pointOf(a.id)), a.id, false, stats))
                deferred_.push_back(a.id);
        }
        splits_.clear();
        if (stats.splits + stats.merges >= options_.work_budget) {
            stats.budget_exhausted = true;
            deferred_.insert(deferred_.end(), due_.begin(), due_.end());
            due_.clear();
        }
    }
    // left for the next frame: due again as soon as it starts
    for (const DiamondId id : deferred_)
        if ((state_[id] & (kSplitCandidate | kMergeCandidate)) != 0)
            heapPush(id, travel_);
}

void Tessellator::finishFrame(const ViewMetric& m, FrameStats& stats) {
    std::uint64_t written = 0;
    for (std::int32_t tile = 0; tile < tileCount(); ++tile) {
        TileMesh& mesh = tiles_[idx(tile)];
        if (mesh.dirty())
            mesh.compactIfSparse();
        written += mesh.counters().index_bytes_written;
        const Diamond root = tileRoot(tile);
        const DiamondId id = idOf(root.centre);
        const std::int32_t tx = tile % spec_.tilesX();
        const std::int32_t ty = tile / spec_.tilesX();
        Box box;
        box.lo = {
            tx * kLatticePerTile * metres_per_lattice_, ty * kLatticePerTile * metres_per_lattice_,
            zlo_[id]};
        box.hi = {
            std::min((tx + 1) * kLatticePerTile, real_x_) * metres_per_lattice_,
            std::min((ty + 1) * kLatticePerTile, real_y_) * metres_per_lattice_, zhi_[id]};
        const bool visible = m.intersectsFrustum(box);
        tile_visible_[idx(tile)] = visible ? 1 : 0;
        stats.triangles += mesh.triangleCount();
        if (visible)
            stats.visible_triangles += mesh.triangleCount();
        stats.index_bytes_total +=
            static_cast<std::int64_t>(mesh.slotCount()) * TileMesh::kIndexBytesPerTriangle;
    }
    stats.index_bytes_written = static_cast<std::int64_t>(written - written_before_);
    written_before_ = written;
    triangles_ = stats.triangles;
}

FrameStats Tessellator::update(const Camera& camera) {
    const ViewMetric m(camera);
    FrameStats stats;
    const double teleport = options_.teleport_metres > 0.0
                                ? options_.teleport_metres
                                : 8.0 * kLatticePerTile * metres_per_lattice_;
    const bool jumped = glm::length(camera.eye - last_eye_) > teleport;
    const bool lens_changed =
        m.errorScale() != last_error_scale_ || camera.near_plane != last_near_;
    if (options_.mode == TessellationMode::kSplitOnly || needs_rebuild_ || !initialized_ ||
        jumped || lens_changed) {
        rebuildTopDown(m, stats);
        needs_rebuild_ = false;
        initialized_ = true;
        sweep_forward_ = glm::normalize(camera.forward);
    } else {
        travel_ += glm::length(camera.eye - last_eye_);
        updateSplitMerge(m, stats);
    }
    last_eye_ = camera.eye;
    last_error_scale_ = m.errorScale();
    last_near_ = camera.near_plane;
    finishFrame(m, stats);
    return stats;
}

bool Tessellator::splitAt(LatticePoint p, FrameStats& stats) {
    const DiamondId id = idOf(p);
    const Diamond d = diamondAt(p);
    if (id == kNoDiamond || !d.valid() || !initialized_)
        return false;
    return activate(d, id, false, stats);
}

void Tessellator::setTau(double tau_pixels) {
    options_.tau_pixels = tau_pixels;
    needs_rebuild_ = true;
}

std::size_t Tessellator::memoryBytes() const {
    std::size_t bytes =
        delta_.capacity() * sizeof(float) * 3 + state_.capacity() +
        heap_pos_.capacity() * sizeof(std::int32_t) + heap_.capacity() * sizeof(HeapEntry) +
        static_cast<std::size_t>(blocks_.capacity()) * (kBlockVertices * sizeof(std::int64_t) + 16);
    for (const TileMesh& t : tiles_)
        bytes += t.memoryBytes();
    return bytes;
}

} // namespace terrain::roam
