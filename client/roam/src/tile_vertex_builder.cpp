#include <terrain/roam/detail_blocks.h>
#include <terrain/roam/tile_vertex_builder.h>

#include <algorithm>
#include <cmath>

namespace terrain::roam {

std::uint32_t packNormal(double nx, double ny, double nz) {
    const auto component = [](double v, int shift) {
        const auto q = static_cast<std::int32_t>(std::lround(std::clamp(v, -1.0, 1.0) * 511.0));
        return (static_cast<std::uint32_t>(q) & 0x3ffu) << shift;
    };
    return component(nx, 0) | component(ny, 10) | component(nz, 20);
}

namespace {

std::uint32_t normalOfSlopes(double dzdx, double dzdy) {
    const double inv = 1.0 / std::sqrt(dzdx * dzdx + dzdy * dzdy + 1.0);
    return packNormal(-dzdx * inv, -dzdy * inv, inv);
}

/// On the base grid: the samples a cell either side (patch corners are pinned to them), one
/// sided at the map's edge; the padding takes the map edge's slope.
std::uint32_t baseNormal(const Terrain& terrain, LatticePoint p) {
    const WorldSpec& spec = terrain.spec();
    const double spacing = spec.spacingMetres();
    const std::int32_t gx = std::min(p.x / kLatticePerCell, spec.width - 1);
    const std::int32_t gy = std::min(p.y / kLatticePerCell, spec.height - 1);
    const std::int32_t ax = std::max(gx - 1, 0);
    const std::int32_t bx = std::min(gx + 1, spec.width - 1);
    const std::int32_t ay = std::max(gy - 1, 0);
    const std::int32_t by = std::min(gy + 1, spec.height - 1);
    const double unit = spec.metresPerUnit();
    double dzdx = 0.0;
    double dzdy = 0.0;
    if (bx > ax)
        dzdx = (terrain.sample(bx, gy) - terrain.sample(ax, gy)) * unit / ((bx - ax) * spacing);
    if (by > ay)
        dzdy = (terrain.sample(gx, by) - terrain.sample(gx, ay)) * unit / ((by - ay) * spacing);
    return normalOfSlopes(dzdx, dzdy);
}

} // namespace

void TileVertexBuilder::positions(
    const Tessellator& tess, std::int32_t tile, std::uint32_t first, std::span<DrawVertex> out) {
    const double per_fine = tess.metresPerFineUnit();
    keys_.resize(out.size());
    tess.tileVertices(tile, first, keys_);
    for (std::size_t i = 0; i < out.size(); ++i) {
        const TileVertex& v = keys_[i];
        // lattice units from the map's corner: whole numbers below 2^24, exact in a float, so
        // every copy of a vertex (tiles, cell blocks) is the same bits
        out[i] = DrawVertex{
            static_cast<float>(v.position.x), static_cast<float>(v.position.y),
            static_cast<float>(static_cast<double>(v.height) * per_fine), 0u};
    }
}

void TileVertexBuilder::newFrame() {
    cell_slot_.clear();
    grids_.clear();
    slot_keys_.clear();
    recently_used_.clear();
    free_slots_.clear();
    hand_ = 0;
    last_key_ = ~std::uint64_t{0};
    last_grid_ = nullptr;
}

void TileVertexBuilder::forget(CellRect cells) {
    last_key_ = ~std::uint64_t{0};
    last_grid_ = nullptr;
    const auto area = static_cast<std::size_t>(cells.x1 - cells.x0 + 1) *
                      static_cast<std::size_t>(cells.y1 - cells.y0 + 1);
    if (area >= cell_slot_.size()) {
        // fewer cached grids than cells in the rectangle: look at each grid
        for (auto it = cell_slot_.begin(); it != cell_slot_.end();) {
            const auto cx = static_cast<std::int32_t>(it->first >> 32);
            const auto cy = static_cast<std::int32_t>(it->first & 0xffffffffu);
            if (cx >= cells.x0 && cx <= cells.x1 && cy >= cells.y0 && cy <= cells.y1) {
                slot_keys_[it->second] = kNoCell;
                free_slots_.push_back(it->second);
                it = cell_slot_.erase(it);
            } else {
                ++it;
            }
        }
        return;
    }
    for (std::int32_t cy = cells.y0; cy <= cells.y1; ++cy)
        for (std::int32_t cx = cells.x0; cx <= cells.x1; ++cx) {
            const std::uint64_t key = (std::uint64_t{static_cast<std::uint32_t>(cx)} << 32) |
                                      static_cast<std::uint32_t>(cy);
            if (const auto it = cell_slot_.find(key); it != cell_slot_.end()) {
                slot_keys_[it->second] = kNoCell;
                free_slots_.push_back(it->second);
                cell_slot_.erase(it);
            }
        }
}

const std::int64_t*
TileVertexBuilder::cellGrid(const Terrain& terrain, std::int32_t cx, std::int32_t cy) {
    const std::uint64_t key =
        (std::uint64_t{static_cast<std::uint32_t>(cx)} << 32) | static_cast<std::uint32_t>(cy);
    if (key == last_key_)
        return last_grid_;
    constexpr auto kCell = static_cast<std::size_t>(kBlockVertices);
    std::uint32_t slot = 0;
    if (const auto it = cell_slot_.find(key); it != cell_slot_.end()) {
        slot = it->second;
    } else {
        if (!free_slots_.empty()) {
            slot = free_slots_.back();
            free_slots_.pop_back();
        } else if (slot_keys_.size() < max_cells_) {
            slot = static_cast<std::uint32_t>(slot_keys_.size());
            slot_keys_.push_back(kNoCell);
            recently_used_.push_back(0);
            grids_.resize(grids_.size() + kCell);
        } else {
            slot = evictOne();
        }
        cell_slot_.emplace(key, slot);
        slot_keys_[slot] = key;
        fillCellHeights(
            terrain, cx, cy,
            std::span<std::int64_t, kBlockVertices>(grids_.data() + slot * kCell, kCell));
    }
    recently_used_[slot] = 1;
    last_key_ = key;
    last_grid_ = grids_.data() + slot * kCell;
    return last_grid_;
}

std::uint32_t TileVertexBuilder::evictOne() {
    // the clock: a grid used since the hand last passed is spared once. Wiping the whole cache
    // when it filled (as until 12-08) made a battle crater's hand-over refill 650-1,400 grids
    // where the cells it changed need about 450
    while (true) {
        const std::uint32_t slot = hand_;
        hand_ = hand_ + 1 == slot_keys_.size() ? 0 : hand_ + 1;
        if (recently_used_[slot] != 0) {
            recently_used_[slot] = 0;
            continue;
        }
        cell_slot_.erase(slot_keys_[slot]);
        slot_keys_[slot] = kNoCell;
        return slot;
    }
}

std::int64_t
TileVertexBuilder::latticeHeight(const Terrain& terrain, std::int32_t x, std::int32_t y) {
    // the owner: the cell at or before the point, the last real cell on the map's far lines
    const WorldSpec& spec = terrain.spec();
    const std::int32_t cx = std::min(x / kLatticePerCell, spec.cellsX() - 1);
    const std::int32_t cy = std::min(y / kLatticePerCell, spec.cellsY() - 1);
    const std::int64_t* grid = cellGrid(terrain, cx, cy);
    const std::int32_t k = x - cx * kLatticePerCell;
    const std::int32_t l = y - cy * kLatticePerCell;
    return grid[static_cast<std::size_t>(l * kBlockSide + k)];
}

std::uint32_t TileVertexBuilder::blockNormal(
    const Terrain& terrain, LatticePoint p, double per_lattice, double per_fine) {
    // one lattice step either side, one sided at the real map's edge (past it, in the padding,
    // the edge's slope)
    const WorldSpec& spec = terrain.spec();
    const std::int32_t max_x = spec.cellsX() * kLatticePerCell;
    const std::int32_t max_y = spec.cellsY() * kLatticePerCell;
    const std::int32_t x = std::min(p.x, max_x);
    const std::int32_t y = std::min(p.y, max_y);
    const std::int32_t x0 = std::max(x - 1, 0);
    const std::int32_t x1 = std::min(x + 1, max_x);
    const std::int32_t y0 = std::max(y - 1, 0);
    const std::int32_t y1 = std::min(y + 1, max_y);
    double dzdx = 0.0;
    double dzdy = 0.0;
    if (x1 > x0)
        dzdx = static_cast<double>(latticeHeight(terrain, x1, y) - latticeHeight(terrain, x0, y)) *
               per_fine / ((x1 - x0) * per_lattice);
    if (y1 > y0)
        dzdy = static_cast<double>(latticeHeight(terrain, x, y1) - latticeHeight(terrain, x, y0)) *
               per_fine / ((y1 - y0) * per_lattice);
    return normalOfSlopes(dzdx, dzdy);
}

void TileVertexBuilder::build(
    const Tessellator& tess,
    const Terrain& terrain,
    std::int32_t tile,
    std::uint32_t first,
    std::span<DrawVertex> out) {
    constexpr auto kBase = static_cast<std::uint32_t>(kTileBaseVertices);
    const double per_lattice = tess.metresPerLattice();
    const double per_fine = tess.metresPerFineUnit();
    positions(tess, tile, first, out);
    for (std::size_t i = 0; i < out.size(); ++i) {
        const auto index = static_cast<std::uint32_t>(first + i);
        const TileVertex& key = keys_[i];
        out[i].normal = index < kBase ? baseNormal(terrain, key.position)
                                      : blockNormal(terrain, key.position, per_lattice, per_fine);
    }
}

void TileVertexBuilder::buildEach(
    const Tessellator& tess,
    const Terrain& terrain,
    std::int32_t tile,
    std::span<const std::uint32_t> indices,
    std::span<DrawVertex> out) {
    std::size_t i = 0;
    while (i < indices.size()) {
        if (indices[i] == kNoVertex) {
            // nothing draws it: a point of the tile (an engine's bounds stay the tile's), facing up
            positions(tess, tile, 0, out.subspan(i, 1));
            out[i++].normal = packNormal(0.0, 0.0, 1.0);
            continue;
        }
        // a run of consecutive indices at once (the array's segments found once a run)
        std::size_t j = i + 1;
        while (j < indices.size() && indices[j] == indices[j - 1] + 1)
            ++j;
        if (j - i == 1) {
            // one vertex (most are: a slot is given to whichever vertex comes next)
            const TileVertex key = tess.tileVertex(tile, indices[i]);
            out[i] = DrawVertex{
                static_cast<float>(key.position.x), static_cast<float>(key.position.y),
                static_cast<float>(static_cast<double>(key.height) * tess.metresPerFineUnit()),
                indices[i] < static_cast<std::uint32_t>(kTileBaseVertices)
                    ? baseNormal(terrain, key.position)
                    : blockNormal(
                          terrain, key.position, tess.metresPerLattice(),
                          tess.metresPerFineUnit())};
            ++i;
            continue;
        }
        build(tess, terrain, tile, indices[i], out.subspan(i, j - i));
        i = j;
    }
}

} // namespace terrain::roam
