#include "tile_source.h"

#include <terrain/render/terrain_program.h>

#include <algorithm>

namespace terrain::render {

std::pair<float, float> TessellatorTiles::heightRange() const {
    return TerrainProgram::heightRange(terrain_);
}

void DrawnTiles::vertices(std::int32_t tile, std::uint32_t first, std::span<GpuVertex> out) const {
    const std::span<const roam::DrawVertex> held = mesh_.vertices(tile);
    std::copy_n(held.begin() + first, out.size(), out.begin());
}

} // namespace terrain::render
