// RendererOptions::validate: what the GPU's buffers hold, read back and compared with a fresh
// build of every resident tile from the tessellator (vertices bit for bit, the index list slot
// for slot, every index inside the vertex array, buffers large enough). Normals are computed
// afresh for the tiles the sync wrote (the costly part: surface queries), and taken from the
// renderer's copy for the vertices of other tiles that did not move.

#include "tile_vertex_builder.h"

#include <terrain/render/terrain_renderer.h>

#include <cstring>

namespace terrain::render {

namespace {

std::string vertexText(const GpuVertex& v) {
    char text[128];
    std::snprintf(text, sizeof text, "(%.3f, %.3f, %.4f, normal %08x)", v.x, v.y, v.z, v.normal);
    return text;
}

} // namespace

void TerrainRenderer::validate(const roam::Tessellator& tess, const Terrain& terrain) {
    ValidationReport& r = validation_;
    ++r.syncs;
    const auto note = [&](const std::string& problem) {
        if (r.first_problem.empty())
            r.first_problem = "sync " + std::to_string(frame_) + ": " + problem;
    };
    written_.resize(tiles_.size(), 0);
    const auto readBack = [&](unsigned buffer, std::uint64_t bytes) -> bool {
        gl_.BindBuffer(GL_COPY_READ_BUFFER, buffer);
        GLint size = 0;
        gl_.GetBufferParameteriv(GL_COPY_READ_BUFFER, GL_BUFFER_SIZE, &size);
        if (static_cast<std::uint64_t>(size) < bytes)
            return false;
        readback_.resize(bytes);
        if (bytes > 0)
            gl_.GetBufferSubData(
                GL_COPY_READ_BUFFER, 0, static_cast<GLsizeiptr>(bytes), readback_.data());
        return true;
    };
    for (std::int32_t t = 0; t < tess.tileCount(); ++t) {
        const TileBuffers& tb = tiles_[static_cast<std::size_t>(t)];
        if (tb.vao == 0)
            continue;
        ++r.tiles;
        const std::string tile = "tile " + std::to_string(t);
        std::uint32_t count = 0;
        if (tb.has_vertices) {
            // a tile written by this sync against a build from nothing, normals and all; the
            // others (unchanged in the buffer since they were last checked so) against a build
            // that takes the normals of vertices that did not move from the buffer's copy:
            // positions and heights are always the tessellator's, fresh
            const bool written = written_[static_cast<std::size_t>(t)] != 0;
            builder_->build(
                tess, terrain, t, written ? std::span<const GpuVertex>() : std::span(tb.shadow), {},
                expected_vertices_);
            count = static_cast<std::uint32_t>(expected_vertices_.size());
            if (!readBack(tb.vertex_buffer, std::uint64_t{count} * sizeof(GpuVertex))) {
                ++r.short_buffers;
                note(
                    tile + ": vertex buffer smaller than its " + std::to_string(count) +
                    " vertices");
                continue;
            }
            r.vertices += count;
            for (std::uint32_t i = 0; i < count; ++i) {
                GpuVertex want = expected_vertices_[i];
                if (tb.morphed && i < tb.drawn_z.size())
                    want.z = tb.drawn_z[i];
                GpuVertex got;
                std::memcpy(
                    &got, readback_.data() + std::size_t{i} * sizeof(GpuVertex), sizeof got);
                if (std::memcmp(&want, &got, sizeof got) != 0) {
                    if (r.vertex_mismatches == 0)
                        note(
                            tile + " vertex " + std::to_string(i) + ": buffer " + vertexText(got) +
                            ", fresh " + vertexText(want));
                    ++r.vertex_mismatches;
                }
            }
        }
        if (tb.has_indices) {
            const roam::TileMesh& mesh = tess.tileMesh(t);
            const std::uint64_t n = std::uint64_t{tb.slots} * 3;
            if (!readBack(tb.index_buffer, n * sizeof(std::uint32_t))) {
                ++r.short_buffers;
                note(
                    tile + ": index buffer smaller than its " + std::to_string(tb.slots) +
                    " slots");
                continue;
            }
            r.indices += n;
            if (mesh.slotCount() != tb.slots) {
                ++r.index_mismatches;
                note(
                    tile + ": " + std::to_string(tb.slots) + " slots drawn, the list has " +
                    std::to_string(mesh.slotCount()));
            }
            const std::span<const std::uint32_t> list = mesh.indices();
            for (std::uint64_t i = 0; i < n; ++i) {
                std::uint32_t got = 0;
                std::memcpy(&got, readback_.data() + i * sizeof got, sizeof got);
                const bool listed = i < list.size() && list[i] == got;
                if (!listed || (tb.has_vertices && got >= count)) {
                    if (r.index_mismatches == 0)
                        note(
                            tile + " index " + std::to_string(i) + ": buffer " +
                            std::to_string(got) + ", list " +
                            (i < list.size() ? std::to_string(list[i]) : "none") + ", " +
                            std::to_string(count) + " vertices");
                    ++r.index_mismatches;
                }
            }
        }
    }
    std::fill(written_.begin(), written_.end(), 0);
}

} // namespace terrain::render
