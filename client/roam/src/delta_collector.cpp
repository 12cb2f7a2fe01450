#include <terrain/assert.h>
#include <terrain/roam/delta_collector.h>

#include <algorithm>
#include <cstring>
#include <limits>

namespace terrain::roam {

namespace {

std::size_t at(std::int64_t v) {
    return static_cast<std::size_t>(v);
}

std::uint32_t pagesOf(std::uint32_t slots) {
    return (slots + TileMesh::kSlotsPerPage - 1) / TileMesh::kSlotsPerPage;
}

} // namespace

void DeltaCollector::delivered() {
    for (const std::int32_t t : pending_tiles_) {
        Pending& p = pending_[at(t)];
        for (const std::uint32_t page : p.pages)
            p.page_flags[page] = 0;
        p.pages.clear();
        for (const std::uint32_t slot : p.slots)
            p.slot_flags[slot] = 0;
        p.slots.clear();
        p.rewritten = false;
        p.all_vertices = false;
        tile_listed_[at(t)] = 0;
    }
    pending_tiles_.clear();
    new_tiles_ = false;
}

void DeltaCollector::markSlot(Pending& p, std::uint32_t slot) {
    if (p.slot_flags[slot] == 0) {
        p.slot_flags[slot] = 1;
        p.slots.push_back(slot);
    }
}

void DeltaCollector::takeChanges(Tessellator& tess, const WorldSpec& spec) {
    const std::int32_t tiles = tess.tileCount();
    const auto list = [&](std::int32_t t) {
        if (tile_listed_[at(t)] == 0) {
            tile_listed_[at(t)] = 1;
            pending_tiles_.push_back(t);
        }
    };
    if (pending_.size() != at(tiles) || !(spec == spec_)) {
        // a new set of tiles (another world): the reader starts over, every tile whole
        spec_ = spec;
        pending_.assign(at(tiles), Pending{});
        tile_listed_.assign(at(tiles), 0);
        pending_tiles_.clear();
        new_tiles_ = true;
    }
    for (std::int32_t t = 0; t < tiles; ++t) {
        Pending& p = pending_[at(t)];
        TileMesh& mesh = tess.tileMesh(t);
        const bool all_vertices = tess.tileVerticesAllChanged(t);
        const auto ranges = tess.tileVertexChanges(t);
        const bool fresh = new_tiles_ && !p.rewritten;
        if (!fresh && !mesh.dirty() && !mesh.slotsRelaid() && !all_vertices && ranges.empty())
            continue;
        list(t);
        if (p.slot_flags.size() < mesh.drawnVertexCount())
            p.slot_flags.resize(mesh.drawnVertexCount(), 0);
        if (fresh || mesh.slotsRelaid()) {
            // the slots were given afresh (or the tiles are new): the list and array whole
            p.rewritten = true;
            p.all_vertices = true;
        } else if (mesh.rewritten()) {
            p.rewritten = true;
        } else if (!p.rewritten) {
            for (const std::uint32_t page : mesh.dirtyPages()) {
                if (page >= p.page_flags.size())
                    p.page_flags.resize(page + 1, 0);
                if (p.page_flags[page] == 0) {
                    p.page_flags[page] = 1;
                    p.pages.push_back(page);
                }
            }
        }
        if (all_vertices || mesh.manyTakenSlots())
            p.all_vertices = true;
        if (!p.all_vertices) {
            // slots given a vertex, and the held vertices that changed; a vertex no triangle
            // uses is built when one comes to
            for (const std::uint32_t slot : mesh.takenSlots())
                markSlot(p, slot);
            const auto count = static_cast<std::uint32_t>(tess.tileVertexCount(t));
            for (const VertexRange& r : ranges)
                for (std::uint32_t v = r.begin; v < std::min(r.end, count); ++v)
                    if (const std::uint32_t slot = mesh.slotOfVertex(v); slot != VertexSlots::kNone)
                        markSlot(p, slot);
        }
        mesh.takeChanges();
        tess.takeVertexChanges(t);
    }
}

void DeltaCollector::collect(Tessellator& tess, const Terrain& terrain, MeshDelta& out) {
    takeChanges(tess, terrain.spec());
    ++step_;
    out.clear();
    out.step = step_;
    out.new_tiles = new_tiles_;
    out.tile_count = tess.tileCount();
    out.spec = terrain.spec();
    if (new_tiles_)
        out.height_range = heightRange(terrain);
    out.visible.resize(at(out.tile_count));
    out.versions.resize(at(out.tile_count));
    for (std::int32_t t = 0; t < out.tile_count; ++t) {
        out.visible[at(t)] = tess.tileVisible(t) ? 1 : 0;
        out.versions[at(t)] = tess.tileVertexVersion(t);
    }
    // ascending tiles: a reader's work and the delta's layout follow the map, not the order of
    // the changes
    std::sort(pending_tiles_.begin(), pending_tiles_.end());
    // the layout first (which pages and runs, where their contents go), then the contents: per
    // group of tiles on the runner, each group with its own builder, each writing its own slots
    for (const std::int32_t t : pending_tiles_)
        layout(tess, t, out);
    out.page_indices.resize(out.pages.size() * MeshDelta::kPageIndices);
    std::size_t vertices = 0;
    for (const MeshDelta::Run& run : out.runs)
        vertices += run.end - run.begin;
    out.vertices.resize(vertices);
    const std::size_t groups = runner_ != nullptr && runner_->threads() > 1 && out.tiles.size() > 1
                                   ? std::min<std::size_t>(runner_->threads(), out.tiles.size())
                                   : 1;
    if (groups_.size() < groups)
        groups_.resize(groups);
    // the builders keep their cells' grids from one collect to the next, but for the cells the
    // terrain changed since (normals read them: a third of a crater's hand-over was refilling
    // the grids of cells no op had touched)
    for (Group& group : groups_) {
        if (tess.allCellsChanged())
            group.builder.newFrame();
        else
            for (const CellRect& r : tess.changedCells())
                group.builder.forget(r);
    }
    tess.takeChangedCells();
    // groups of consecutive tiles holding about the same number of vertices
    group_ends_.assign(groups, out.tiles.size());
    std::size_t g = 0;
    std::size_t done = 0;
    for (std::size_t k = 0; k < out.tiles.size() && g + 1 < groups; ++k) {
        const MeshDelta::Tile& e = out.tiles[k];
        for (std::uint32_t r = e.first_run; r < e.first_run + e.run_count; ++r)
            done += out.runs[r].end - out.runs[r].begin;
        if (done * groups >= (g + 1) * std::max<std::size_t>(vertices, 1))
            group_ends_[g++] = k + 1;
    }
    forEachTask(runner_, groups, 2, [&](std::size_t group) {
        const std::size_t first = group == 0 ? 0 : group_ends_[group - 1];
        for (std::size_t k = first; k < group_ends_[group]; ++k)
            fill(tess, terrain, out.tiles[k], groups_[group], out);
    });
}

void DeltaCollector::layout(const Tessellator& tess, std::int32_t t, MeshDelta& out) {
    Pending& p = pending_[at(t)];
    const TileMesh& mesh = tess.tileMesh(t);
    MeshDelta::Tile entry;
    entry.tile = t;
    entry.slot_count = mesh.slotCount();
    entry.vertex_count = mesh.drawnVertexCount();
    entry.vertex_version = tess.tileVertexVersion(t);
    entry.indices_rewritten = p.rewritten;
    entry.vertices_reset = p.all_vertices;

    // index pages: all of the list after a rebuild, else the pages written that it still holds
    const std::uint32_t live_pages = pagesOf(entry.slot_count);
    entry.first_page = static_cast<std::uint32_t>(out.pages.size());
    if (p.rewritten) {
        for (std::uint32_t page = 0; page < live_pages; ++page)
            out.pages.push_back(page);
    } else {
        std::sort(p.pages.begin(), p.pages.end());
        for (const std::uint32_t page : p.pages)
            if (page < live_pages)
                out.pages.push_back(page);
    }
    entry.page_count = static_cast<std::uint32_t>(out.pages.size()) - entry.first_page;

    // slot runs, their values at consecutive places in out.vertices
    entry.first_run = static_cast<std::uint32_t>(out.runs.size());
    std::uint64_t at_vertex =
        out.runs.empty() ? 0 : out.runs.back().at + (out.runs.back().end - out.runs.back().begin);
    if (p.all_vertices) {
        if (entry.vertex_count > 0)
            out.runs.push_back({0, entry.vertex_count, at_vertex});
    } else {
        std::sort(p.slots.begin(), p.slots.end());
        // (the slots shrink only when given afresh, and then every slot is pending)
        TERRAIN_ASSERT(p.slots.empty() || p.slots.back() < entry.vertex_count);
        for (std::size_t k = 0; k < p.slots.size();) {
            std::size_t j = k + 1;
            while (j < p.slots.size() && p.slots[j] == p.slots[j - 1] + 1)
                ++j;
            const std::uint32_t begin = p.slots[k];
            const auto end = begin + static_cast<std::uint32_t>(j - k);
            out.runs.push_back({begin, end, at_vertex});
            at_vertex += end - begin;
            k = j;
        }
    }
    entry.run_count = static_cast<std::uint32_t>(out.runs.size()) - entry.first_run;
    out.tiles.push_back(entry);
}

void DeltaCollector::fill(
    const Tessellator& tess,
    const Terrain& terrain,
    const MeshDelta::Tile& entry,
    Group& group,
    MeshDelta& out) {
    const TileMesh& mesh = tess.tileMesh(entry.tile);
    const std::span<const std::uint32_t> indices = mesh.drawnIndices();
    for (std::uint32_t k = entry.first_page; k < entry.first_page + entry.page_count; ++k) {
        const std::size_t from = std::size_t{out.pages[k]} * MeshDelta::kPageIndices;
        const std::size_t n = std::min<std::size_t>(MeshDelta::kPageIndices, indices.size() - from);
        std::uint32_t* into = out.page_indices.data() + std::size_t{k} * MeshDelta::kPageIndices;
        std::memcpy(into, indices.data() + from, n * sizeof(std::uint32_t));
        std::fill(into + n, into + MeshDelta::kPageIndices, 0u);
    }
    // the slots' vertices as drawn (normals from `terrain`); a free slot stands in
    for (std::uint32_t k = entry.first_run; k < entry.first_run + entry.run_count; ++k) {
        const MeshDelta::Run& run = out.runs[k];
        group.vertices.resize(run.end - run.begin);
        for (std::uint32_t slot = run.begin; slot < run.end; ++slot)
            group.vertices[slot - run.begin] = mesh.vertexOfSlot(slot);
        group.builder.buildEach(
            tess, terrain, entry.tile, group.vertices,
            std::span<DrawVertex>(out.vertices.data() + run.at, run.end - run.begin));
    }
}

std::pair<float, float> DeltaCollector::heightRange(const Terrain& terrain) {
    const WorldSpec& spec = terrain.spec();
    float lo = std::numeric_limits<float>::max();
    float hi = std::numeric_limits<float>::lowest();
    for (std::int32_t y = 0; y < spec.height; ++y)
        for (std::int32_t x = 0; x < spec.width; ++x) {
            const auto z = static_cast<float>(terrain.sample(x, y) * spec.metresPerUnit());
            lo = std::min(lo, z);
            hi = std::max(hi, z);
        }
    return lo <= hi ? std::pair{lo, hi} : std::pair{0.0f, 0.0f};
}

std::uint64_t DeltaCollector::slotCount(const Tessellator& tess) {
    std::uint64_t n = 0;
    for (std::int32_t t = 0; t < tess.tileCount(); ++t)
        n += tess.tileMesh(t).drawnVertexCount();
    return n;
}

std::uint64_t DeltaCollector::tessellatorVertexCount(const Tessellator& tess) {
    std::uint64_t n = 0;
    for (std::int32_t t = 0; t < tess.tileCount(); ++t)
        n += static_cast<std::uint64_t>(tess.tileVertexCount(t));
    return n;
}

std::size_t DeltaCollector::memoryBytes() const {
    std::size_t n = pending_.capacity() * sizeof(Pending);
    for (const Pending& p : pending_)
        n += (p.slots.capacity() + p.pages.capacity()) * sizeof(std::uint32_t) +
             p.slot_flags.capacity() + p.page_flags.capacity();
    for (const Group& g : groups_)
        n += g.vertices.capacity() * sizeof(std::uint32_t);
    return n;
}

} // namespace terrain::roam
