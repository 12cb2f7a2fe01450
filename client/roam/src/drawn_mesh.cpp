#include <terrain/roam/drawn_mesh.h>
#include <terrain/roam/lattice.h>

#include <algorithm>
#include <cstring>
#include <limits>

namespace terrain::roam {

void DrawnMesh::markPage(TileCopy& copy, std::uint32_t page) {
    if (page >= copy.page_flags.size())
        copy.page_flags.resize(page + 1, 0);
    if (copy.page_flags[page] == 0) {
        copy.page_flags[page] = 1;
        copy.dirty_pages.push_back(page);
    }
}

template <typename T> void DrawnMesh::fitCapacity(std::vector<T>& v) {
    // a tile laid out afresh with far less than it held (the view moved away): give it back
    if (v.capacity() > 2 * v.size() + 1024)
        v.shrink_to_fit();
}

bool DrawnMesh::wellFormed(const MeshDelta& delta) {
    if (delta.tile_count < 0 || delta.visible.size() != at(delta.tile_count) ||
        delta.versions.size() != at(delta.tile_count) ||
        delta.page_indices.size() != delta.pages.size() * MeshDelta::kPageIndices)
        return false;
    for (const MeshDelta::Tile& e : delta.tiles) {
        if (e.tile < 0 || e.tile >= delta.tile_count ||
            std::size_t{e.first_page} + e.page_count > delta.pages.size() ||
            std::size_t{e.first_run} + e.run_count > delta.runs.size())
            return false;
        const std::uint32_t pages =
            (e.slot_count + TileMesh::kSlotsPerPage - 1) / TileMesh::kSlotsPerPage;
        for (std::uint32_t k = e.first_page; k < e.first_page + e.page_count; ++k)
            if (delta.pages[k] >= pages)
                return false;
        for (std::uint32_t k = e.first_run; k < e.first_run + e.run_count; ++k) {
            const MeshDelta::Run& r = delta.runs[k];
            if (r.begin > r.end || r.end > e.vertex_count || r.at > delta.vertices.size() ||
                r.end - r.begin > delta.vertices.size() - r.at)
                return false;
        }
    }
    return true;
}

bool DrawnMesh::apply(const MeshDelta& delta) {
    if (delta.step <= step_ && !delta.new_tiles)
        return false;
    // a delta for other tiles than the copy's must start them over (one was missed: a bug)
    if (!delta.new_tiles && delta.tile_count != tileCount())
        return false;
    if (!wellFormed(delta))
        return false;
    if (delta.new_tiles) {
        tiles_.assign(at(delta.tile_count), TileCopy{});
        spec_ = delta.spec;
    }
    step_ = delta.step;
    const auto per_lattice = static_cast<float>(metresPerLattice(spec_));
    for (std::int32_t t = 0; t < delta.tile_count; ++t) {
        tiles_[at(t)].visible = delta.visible[at(t)] != 0;
        tiles_[at(t)].version = delta.versions[at(t)];
    }
    for (const MeshDelta::Tile& e : delta.tiles) {
        TileCopy& copy = tiles_[at(e.tile)];
        // the list: its new length, then the pages (a page cut by the end is padded in the delta)
        const std::size_t index_count = std::size_t{e.slot_count} * 3;
        copy.indices.resize(index_count);
        if (e.indices_rewritten) {
            fitCapacity(copy.indices);
            copy.rewritten = true;
            for (const std::uint32_t page : copy.dirty_pages)
                copy.page_flags[page] = 0;
            copy.dirty_pages.clear();
        }
        for (std::uint32_t k = e.first_page; k < e.first_page + e.page_count; ++k) {
            const std::uint32_t page = delta.pages[k];
            const std::size_t from = std::size_t{page} * MeshDelta::kPageIndices;
            const std::size_t n =
                std::min<std::size_t>(MeshDelta::kPageIndices, index_count - from);
            std::memcpy(
                copy.indices.data() + from,
                delta.page_indices.data() + std::size_t{k} * MeshDelta::kPageIndices,
                n * sizeof(std::uint32_t));
            if (!copy.rewritten)
                markPage(copy, page);
        }
        // the array: its new size, then the runs
        copy.vertices.resize(e.vertex_count);
        if (e.vertices_reset) {
            fitCapacity(copy.vertices);
            copy.all_vertices = true;
            copy.vertex_changes.clear();
        }
        for (std::uint32_t k = e.first_run; k < e.first_run + e.run_count; ++k) {
            const MeshDelta::Run& run = delta.runs[k];
            std::memcpy(
                copy.vertices.data() + run.begin, delta.vertices.data() + run.at,
                std::size_t{run.end - run.begin} * sizeof(DrawVertex));
            if (units_ == Units::kMetres)
                for (std::uint32_t v = run.begin; v < run.end; ++v) {
                    copy.vertices[v].x *= per_lattice;
                    copy.vertices[v].y *= per_lattice;
                }
            if (!copy.all_vertices)
                copy.vertex_changes.push_back({run.begin, run.end});
        }
        if (copy.vertex_changes.size() > TileVertexArrays::kMaxRanges) {
            // no renderer is taking them: "everything", as the tessellator does
            copy.all_vertices = true;
            copy.vertex_changes.clear();
        }
    }
    if (delta.new_tiles)
        height_range_ = delta.height_range;
    return true;
}

double DrawnMesh::metresPerLattice(const WorldSpec& spec) {
    return spec.spacingMetres() / kLatticePerCell;
}

void DrawnMesh::takeVertexChanges(std::int32_t tile) {
    TileCopy& copy = tiles_[at(tile)];
    copy.vertex_changes.clear();
    copy.all_vertices = false;
}

void DrawnMesh::takeIndexChanges(std::int32_t tile) {
    TileCopy& copy = tiles_[at(tile)];
    for (const std::uint32_t page : copy.dirty_pages)
        copy.page_flags[page] = 0;
    copy.dirty_pages.clear();
    copy.rewritten = false;
}

std::size_t DrawnMesh::memoryBytes() const {
    std::size_t bytes = tiles_.capacity() * sizeof(TileCopy);
    for (const TileCopy& c : tiles_)
        bytes += c.indices.capacity() * sizeof(std::uint32_t) +
                 c.vertices.capacity() * sizeof(DrawVertex) +
                 c.dirty_pages.capacity() * sizeof(std::uint32_t) + c.page_flags.capacity() +
                 c.vertex_changes.capacity() * sizeof(VertexRange);
    return bytes;
}

} // namespace terrain::roam
