#include <terrain/roam/move_census.h>

#include <algorithm>

namespace terrain::roam {

void MoveCensus::Window::clear() {
    ids.assign(kWindowSlots, kNoDiamond);
    splits.assign(kWindowSlots, 0);
    used = 0;
}

std::size_t MoveCensus::Window::find(DiamondId id) const {
    const std::size_t mask = ids.size() - 1;
    std::size_t i = (static_cast<std::size_t>(id) * 0x9e3779b97f4a7c15ull) >> 45 & mask;
    for (std::size_t probes = 0; probes < ids.size(); ++probes, i = (i + 1) & mask)
        if (ids[i] == id || ids[i] == kNoDiamond)
            return i;
    return ids.size();
}

void MoveCensus::reset(std::int32_t cells_x, std::int32_t cells_y) {
    squares_x_ = (cells_x + 1) / 2;
    squares_y_ = (cells_y + 1) / 2;
    changed_at_.assign(
        static_cast<std::size_t>(squares_x_) * static_cast<std::size_t>(squares_y_), 0);
    for (Window& w : windows_)
        w.clear();
    window_ = 0;
}

void MoveCensus::changed(CellRect cells, std::uint64_t frame) {
    // one cell of margin: the ring where the core straightens patches, and diamonds centred on
    // the footprint's border
    const std::int32_t x0 = std::max(0, (cells.x0 - 1) / 2);
    const std::int32_t y0 = std::max(0, (cells.y0 - 1) / 2);
    const std::int32_t x1 = std::min(squares_x_ - 1, (cells.x1 + 1) / 2);
    const std::int32_t y1 = std::min(squares_y_ - 1, (cells.y1 + 1) / 2);
    for (std::int32_t y = y0; y <= y1; ++y)
        for (std::int32_t x = x0; x <= x1; ++x)
            changed_at_
                [static_cast<std::size_t>(y) * static_cast<std::size_t>(squares_x_) +
                 static_cast<std::size_t>(x)] = frame;
}

void MoveCensus::moved(
    LatticePoint centre, DiamondId id, bool split, std::uint64_t frame, FrameStats& stats) {
    const std::int32_t sx = centre.x / (2 * kLatticePerCell);
    const std::int32_t sy = centre.y / (2 * kLatticePerCell);
    if (sx >= 0 && sy >= 0 && sx < squares_x_ && sy < squares_y_) {
        const std::uint64_t at = changed_at_
            [static_cast<std::size_t>(sy) * static_cast<std::size_t>(squares_x_) +
             static_cast<std::size_t>(sx)];
        if (at != 0 && frame >= at && frame - at < kRecentFrames)
            ++stats.moves_in_footprint;
    }
    // the windows follow the frames: a new one starts empty, the last one is kept
    const std::uint64_t window = frame / kRecentFrames;
    if (window != window_) {
        windows_[window % 2].clear();
        if (window > window_ + 1)
            windows_[(window + 1) % 2].clear();
        window_ = window;
    }
    Window& current = windows_[window % 2];
    const Window& last = windows_[(window + 1) % 2];
    const std::size_t here = current.find(id);
    bool undone = false;
    if (here < current.ids.size() && current.ids[here] == id) {
        undone = (current.splits[here] != 0) != split;
    } else if (const std::size_t there = last.find(id);
               there < last.ids.size() && last.ids[there] == id) {
        undone = (last.splits[there] != 0) != split;
    }
    if (undone)
        ++stats.moves_undone;
    // at most half full: past it, moves go uncounted as undone until the next window
    if (here < current.ids.size() && (current.ids[here] == id || current.used * 2 < kWindowSlots)) {
        if (current.ids[here] != id)
            ++current.used;
        current.ids[here] = id;
        current.splits[here] = split ? 1 : 0;
    }
}

} // namespace terrain::roam
