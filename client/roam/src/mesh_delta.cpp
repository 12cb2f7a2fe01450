#include <terrain/roam/mesh_delta.h>

namespace terrain::roam {

void MeshDelta::clear() {
    step = 0;
    new_tiles = false;
    tile_count = 0;
    height_range = {0.0f, 0.0f};
    visible.clear();
    versions.clear();
    tiles.clear();
    pages.clear();
    page_indices.clear();
    runs.clear();
    vertices.clear();
}

std::size_t MeshDelta::memoryBytes() const {
    return visible.capacity() + versions.capacity() * sizeof(std::uint32_t) +
           tiles.capacity() * sizeof(Tile) + pages.capacity() * sizeof(std::uint32_t) +
           page_indices.capacity() * sizeof(std::uint32_t) + runs.capacity() * sizeof(Run) +
           vertices.capacity() * sizeof(DrawVertex);
}

} // namespace terrain::roam
