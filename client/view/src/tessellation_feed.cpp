#include <terrain/client/tessellation_feed.h>

#include <algorithm>
#include <vector>

namespace terrain::client {

SurfaceChanges surfaceChanges(const DirtySet& dirty, const WorldSpec& spec) {
    SurfaceChanges changes;
    changes.all = dirty.all;
    if (dirty.all)
        return changes;
    changes.cells.assign(dirty.cells.begin(), dirty.cells.end());
    for (const std::int32_t tile : dirty.tiles) {
        const std::int32_t x0 = (tile % spec.tilesX()) * kTileCells;
        const std::int32_t y0 = (tile / spec.tilesX()) * kTileCells;
        changes.cells.push_back(CellRect{
            x0, y0, std::min(x0 + kTileCells, spec.cellsX()) - 1,
            std::min(y0 + kTileCells, spec.cellsY()) - 1});
    }
    return changes;
}

bool feedChanges(const SurfaceChanges& changes, roam::Tessellator& tess) {
    if (!changes.any())
        return false;
    tess.terrainChanged(changes.cells, changes.all);
    return true;
}

} // namespace terrain::client
