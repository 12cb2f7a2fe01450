#include <terrain/roam/stale_blocks.h>

#include <algorithm>

namespace terrain::roam {

void StaleBlocks::clear() {
    queue_.clear();
    flags_.clear();
}

void StaleBlocks::mark(
    CellRect cells,
    const DetailBlocks& blocks,
    std::int32_t real_cells_x,
    std::int32_t real_cells_y) {
    const CellRect around{
        std::max(0, cells.x0 - 1), std::max(0, cells.y0 - 1),
        std::min(blocks.cellsX() - 1, cells.x1 + 1), std::min(blocks.cellsY() - 1, cells.y1 + 1)};
    flags_.resize(static_cast<std::size_t>(blocks.capacity()), 0);
    for (std::int32_t cy = around.y0; cy <= around.y1; ++cy)
        for (std::int32_t cx = around.x0; cx <= around.x1; ++cx) {
            const std::int32_t b = blocks.blockOf(cx, cy);
            if (b < 0)
                continue;
            std::uint8_t& flag = flags_[static_cast<std::size_t>(b)];
            if (flag == 0)
                queue_.push_back(b);
            flag |= kBounds;
            const bool changed =
                cx >= cells.x0 && cx <= cells.x1 && cy >= cells.y0 && cy <= cells.y1;
            if (changed || cx >= real_cells_x || cy >= real_cells_y)
                flag |= kHeights;
        }
}

void StaleBlocks::takeHeights(std::vector<std::int32_t>& out) {
    out.clear();
    for (const std::int32_t b : queue_) {
        std::uint8_t& flag = flags_[static_cast<std::size_t>(b)];
        if ((flag & kHeights) == 0)
            continue;
        flag = static_cast<std::uint8_t>(flag & ~kHeights);
        out.push_back(b);
    }
}

void StaleBlocks::take(std::int64_t budget, std::vector<std::int32_t>& out) {
    // oldest first; a block forgotten since (its flag cleared) is skipped
    out.clear();
    std::size_t taken = 0;
    while (taken < queue_.size() && static_cast<std::int64_t>(out.size()) < budget) {
        const std::int32_t b = queue_[taken++];
        if (stale(b)) {
            flags_[static_cast<std::size_t>(b)] = 0; // the caller redoes its heights too
            out.push_back(b);
        }
    }
    queue_.erase(queue_.begin(), queue_.begin() + static_cast<std::ptrdiff_t>(taken));
}

} // namespace terrain::roam
