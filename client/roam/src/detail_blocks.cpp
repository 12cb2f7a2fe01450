#include <terrain/fixed_point.h>
#include <terrain/roam/detail_blocks.h>

#include <algorithm>

namespace terrain::roam {

namespace {

static_assert(kFineUnitsPerQuantum == kBlockSide - 1, "fine units make 1/16-cell points exact");

std::int64_t exactBaseHeight(const CellCorners& c, Diagonal d, std::int32_t k, std::int32_t l) {
    return baseHeightScaled(c, d, k, l, kBlockSide - 1);
}

} // namespace

void DetailBlocks::reset(const Terrain& t) {
    // one virtual column and row past the padded grid: a diamond on the map's last line belongs
    // to the cell on its +x / +y side, so a patch on an unpadded border needs a block there
    cells_x_ = t.spec().paddedWidth();
    cells_y_ = t.spec().paddedHeight();
    block_of_cell_.assign(
        static_cast<std::size_t>(cells_x_) * static_cast<std::size_t>(cells_y_), -1);
    cell_of_block_.clear();
    free_.clear();
    heights_.clear();
    finest_error_.clear();
    has_patch_.clear();
    // every patch cell marks its halo, in cell order so slot ids are deterministic
    std::vector<std::uint8_t> needed(block_of_cell_.size(), 0);
    for (std::int32_t tile = 0; tile < t.spec().tileCount(); ++tile) {
        const std::int32_t tx = tile % t.spec().tilesX();
        const std::int32_t ty = tile / t.spec().tilesX();
        for (const PatchEntry& e : t.tilePatches(tile)) {
            const std::int32_t cx = tx * kTileCells + e.cell % kTileCells;
            const std::int32_t cy = ty * kTileCells + e.cell / kTileCells;
            for (std::int32_t y = std::max(0, cy - kDetailHaloCells);
                 y <= std::min(cells_y_ - 1, cy + kDetailHaloCells); ++y)
                for (std::int32_t x = std::max(0, cx - kDetailHaloCells);
                     x <= std::min(cells_x_ - 1, cx + kDetailHaloCells); ++x)
                    needed
                        [static_cast<std::size_t>(y) * static_cast<std::size_t>(cells_x_) +
                         static_cast<std::size_t>(x)] = 1;
        }
    }
    for (std::int32_t y = 0; y < cells_y_; ++y)
        for (std::int32_t x = 0; x < cells_x_; ++x)
            if (needed
                    [static_cast<std::size_t>(y) * static_cast<std::size_t>(cells_x_) +
                     static_cast<std::size_t>(x)] != 0)
                fill(t, take(x, y));
}

bool DetailBlocks::needsBlock(const Terrain& t, std::int32_t cx, std::int32_t cy) const {
    const std::int32_t real_x = t.spec().cellsX();
    const std::int32_t real_y = t.spec().cellsY();
    for (std::int32_t y = std::max(0, cy - kDetailHaloCells);
         y <= std::min(real_y - 1, cy + kDetailHaloCells); ++y)
        for (std::int32_t x = std::max(0, cx - kDetailHaloCells);
             x <= std::min(real_x - 1, cx + kDetailHaloCells); ++x)
            if (t.findPatch(x, y) != nullptr)
                return true;
    return false;
}

CellRect DetailBlocks::aroundChange(CellRect cells) const {
    // a patch appearing or going changes the needs of cells up to the halo away
    return {
        std::max(0, cells.x0 - kDetailHaloCells), std::max(0, cells.y0 - kDetailHaloCells),
        std::min(cells_x_ - 1, cells.x1 + kDetailHaloCells),
        std::min(cells_y_ - 1, cells.y1 + kDetailHaloCells)};
}

void DetailBlocks::plan(
    const Terrain& t, CellRect cells, std::vector<std::int32_t>& removing) const {
    if (cells.empty())
        return;
    const auto [x0, y0, x1, y1] = aroundChange(cells);
    for (std::int32_t y = y0; y <= y1; ++y)
        for (std::int32_t x = x0; x <= x1; ++x)
            if (const std::int32_t block = blockOf(x, y); block >= 0 && !needsBlock(t, x, y))
                removing.push_back(block);
}

void DetailBlocks::update(
    const Terrain& t,
    CellRect cells,
    std::vector<std::int32_t>& removed,
    std::vector<std::int32_t>& added) {
    if (cells.empty())
        return;
    const auto [x0, y0, x1, y1] = aroundChange(cells);
    for (std::int32_t y = y0; y <= y1; ++y) {
        for (std::int32_t x = x0; x <= x1; ++x) {
            const bool need = needsBlock(t, x, y);
            const std::int32_t block = blockOf(x, y);
            if (need && block < 0) {
                const std::int32_t b = take(x, y);
                fill(t, b);
                added.push_back(b);
            } else if (!need && block >= 0) {
                release(block);
                removed.push_back(block);
            } else if (
                block >= 0 && x >= cells.x0 && x <= cells.x1 && y >= cells.y0 && y <= cells.y1) {
                fill(t, block);
            }
        }
    }
}

std::int32_t DetailBlocks::take(std::int32_t cx, std::int32_t cy) {
    std::int32_t block = 0;
    if (!free_.empty()) {
        block = free_.back();
        free_.pop_back();
    } else {
        block = capacity();
        cell_of_block_.emplace_back();
        heights_.resize(heights_.size() + kBlockVertices);
        finest_error_.push_back(0.0f);
        has_patch_.push_back(0);
    }
    cell_of_block_[idx(block)] = {cx, cy};
    block_of_cell_
        [static_cast<std::size_t>(cy) * static_cast<std::size_t>(cells_x_) +
         static_cast<std::size_t>(cx)] = block;
    return block;
}

void DetailBlocks::release(std::int32_t block) {
    const CellXY c = cell_of_block_[idx(block)];
    block_of_cell_
        [static_cast<std::size_t>(c.y) * static_cast<std::size_t>(cells_x_) +
         static_cast<std::size_t>(c.x)] = -1;
    cell_of_block_[idx(block)] = {};
    free_.push_back(block);
}

void DetailBlocks::fill(const Terrain& t, std::int32_t block) {
    const CellXY c = cell_of_block_[idx(block)];
    std::int64_t* out = heights_.data() + idx(block) * kBlockVertices;
    const std::int32_t last_x = t.spec().paddedWidth() - 2; // last cell of the padded grid
    const std::int32_t last_y = t.spec().paddedHeight() - 2;
    if (c.x > last_x || c.y > last_y) {
        // a virtual cell past the grid: it carries diamond state only; the tessellator takes
        // heights on the map's last line from the real cell before it
        std::fill(out, out + kBlockVertices, std::int64_t{0});
        has_patch_[idx(block)] = 0;
        finest_error_[idx(block)] = 0.0f;
        return;
    }
    const bool real = c.x < t.spec().cellsX() && c.y < t.spec().cellsY();
    const DetailPatch* patch = real ? t.findPatch(c.x, c.y) : nullptr;
    has_patch_[idx(block)] = patch != nullptr ? 1 : 0;
    if (patch != nullptr) {
        std::array<std::int64_t, kPatchGridVertices> numerators{};
        gridNumerators(*patch, numerators);
        for (std::size_t i = 0; i < numerators.size(); ++i)
            out[i] = roundDiv(numerators[i] * kFineUnitsPerQuantum, kGridDenominator);
        // the bound already allows half a quantum of rounding; ours is 1/32
        finest_error_[idx(block)] =
            patch->grid_error_bound * static_cast<float>(kFineUnitsPerQuantum);
        return;
    }
    const CellCorners corners = t.corners(c.x, c.y);
    const Diagonal d = cellDiagonal(c.x, c.y);
    for (std::int32_t l = 0; l < kBlockSide; ++l)
        for (std::int32_t k = 0; k < kBlockSide; ++k)
            out[l * kBlockSide + k] = exactBaseHeight(corners, d, k, l);
    finest_error_[idx(block)] = 0.0f;
}

} // namespace terrain::roam
