#include <terrain/client/tessellation_feed.h>

#include <algorithm>
#include <vector>

namespace terrain::client {

std::vector<CellRect> changedCells(const DirtySet& dirty, const WorldSpec& spec) {
    std::vector<CellRect> rects(dirty.cells.begin(), dirty.cells.end());
    for (const std::int32_t tile : dirty.tiles) {
        const std::int32_t x0 = (tile % spec.tilesX()) * kTileCells;
        const std::int32_t y0 = (tile / spec.tilesX()) * kTileCells;
        rects.push_back(CellRect{
            x0, y0, std::min(x0 + kTileCells, spec.cellsX()) - 1,
            std::min(y0 + kTileCells, spec.cellsY()) - 1});
    }
    return rects;
}

bool feedChanges(const DirtySet& dirty, const WorldSpec& spec, roam::Tessellator& tess) {
    if (dirty.all) {
        tess.terrainChanged({}, true);
        return true;
    }
    if (dirty.cells.empty() && dirty.tiles.empty())
        return false;
    tess.terrainChanged(changedCells(dirty, spec), false);
    return true;
}

} // namespace terrain::client
