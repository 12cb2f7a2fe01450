#include <terrain/roam/tile_vertex_arrays.h>

namespace terrain::roam {

void TileVertexArrays::reset(std::size_t tiles) {
    segments_.clear();
    segments_.resize(tiles);
    holes_.clear();
    holes_.resize(tiles);
    extra_.assign(tiles, 0);
    version_.assign(tiles, 0);
    changes_.clear();
    changes_.resize(tiles);
    all_.assign(tiles, 1);
}

void TileVertexArrays::clearTile(std::int32_t tile) {
    segments_[gi(tile)].clear();
    for (auto& holes : holes_[gi(tile)])
        holes.clear();
    extra_[gi(tile)] = 0;
}

std::int32_t TileVertexArrays::attach(std::int32_t tile, int g, std::int32_t chunk) {
    auto& segments = segments_[gi(tile)];
    auto& holes = holes_[gi(tile)][gi(g)];
    std::int32_t segment = 0;
    if (!holes.empty()) {
        segment = holes.back();
        holes.pop_back();
    } else {
        segment = static_cast<std::int32_t>(segments.size());
        segments.push_back({extra_[gi(tile)], -1, g});
        extra_[gi(tile)] += kGrainVertices[gi(g)];
    }
    segments[gi(segment)].chunk = chunk;
    ++version_[gi(tile)];
    const std::uint32_t first = firstVertex(tile, segment);
    mark(tile, first, first + static_cast<std::uint32_t>(kGrainVertices[gi(g)]));
    return segment;
}

void TileVertexArrays::detach(std::int32_t tile, int g, std::int32_t segment) {
    segments_[gi(tile)][gi(segment)].chunk = -1;
    holes_[gi(tile)][gi(g)].push_back(segment);
    ++version_[gi(tile)];
}

void TileVertexArrays::mark(std::int32_t tile, std::uint32_t begin, std::uint32_t end) {
    if (all_[gi(tile)] != 0 || begin >= end)
        return;
    auto& ranges = changes_[gi(tile)];
    if (!ranges.empty() && ranges.back().end == begin) {
        ranges.back().end = end; // the next run of a row, the next segment
        return;
    }
    if (ranges.size() >= kMaxRanges) {
        // no renderer is taking this tile's changes: it loads whole when one does
        markAll(tile);
        return;
    }
    ranges.push_back({begin, end});
}

void TileVertexArrays::markAll(std::int32_t tile) {
    all_[gi(tile)] = 1;
    std::vector<VertexRange>().swap(changes_[gi(tile)]);
}

void TileVertexArrays::take(std::int32_t tile) {
    changes_[gi(tile)].clear();
    all_[gi(tile)] = 0;
}

std::size_t TileVertexArrays::memoryBytes() const {
    std::size_t n = 0;
    for (std::size_t t = 0; t < segments_.size(); ++t) {
        n += segments_[t].capacity() * sizeof(VertexSegment);
        n += changes_[t].capacity() * sizeof(VertexRange);
        for (const auto& h : holes_[t])
            n += h.capacity() * sizeof(std::int32_t);
    }
    return n;
}

} // namespace terrain::roam
