// RendererOptions::validate: what the GPU's buffers hold, read back and compared, for every
// resident tile, with what the renderer sent (every vertex, the index list slot for slot) and
// with a fresh build from the source (the tessellator, or the worker's copy): every index inside
// the vertex array, every vertex an index refers to at its position and height bit for bit, and,
// for one tile per call in turn (the costly part: surface queries), its normal too. Vertices no
// index refers to (a grain gone) may hold anything.

#include "tile_source.h"

#include <terrain/render/terrain_renderer.h>

#include <algorithm>
#include <cstring>

namespace terrain::render {

namespace {

std::string vertexText(const GpuVertex& v) {
    char text[128];
    std::snprintf(text, sizeof text, "(%.3f, %.3f, %.4f, normal %08x)", v.x, v.y, v.z, v.normal);
    return text;
}

bool sameBits(const GpuVertex& a, const GpuVertex& b) {
    return std::memcmp(&a, &b, sizeof a) == 0;
}

} // namespace

void TerrainRenderer::validate(const TileSource& source) {
    ValidationReport& r = validation_;
    ++r.syncs;
    const auto note = [&](const std::string& problem) {
        if (r.first_problem.empty())
            r.first_problem = "sync " + std::to_string(frame_) + ": " + problem;
    };
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
    // the tile whose normals this call recomputes: the next resident one after the last
    std::int32_t normals_tile = -1;
    for (std::int32_t k = 1; k <= source.tileCount(); ++k) {
        const std::int32_t t = (validated_normals_ + k) % source.tileCount();
        if (tiles_[static_cast<std::size_t>(t)].has_vertices) {
            normals_tile = t;
            break;
        }
    }
    if (normals_tile >= 0)
        validated_normals_ = normals_tile;
    builder_->newFrame(); // the terrain may have changed since the sync (morph() validates too)

    for (std::int32_t t = 0; t < source.tileCount(); ++t) {
        const TileBuffers& tb = tiles_[static_cast<std::size_t>(t)];
        if (tb.vao == 0)
            continue;
        ++r.tiles;
        const std::string tile = "tile " + std::to_string(t);
        const auto count = static_cast<std::uint32_t>(tb.shadow.size());
        if (tb.has_vertices) {
            if (count != source.vertexCount(t)) {
                ++r.vertex_mismatches;
                note(
                    tile + ": " + std::to_string(count) + " vertices sent, the array has " +
                    std::to_string(source.vertexCount(t)));
                continue;
            }
            if (!readBack(tb.vertex_buffer, std::uint64_t{count} * sizeof(GpuVertex))) {
                ++r.short_buffers;
                note(
                    tile + ": vertex buffer smaller than its " + std::to_string(count) +
                    " vertices");
                continue;
            }
            r.vertices += count;
            // what changed since the last look (a tile loaded since has nothing to compare)
            TileBuffers& held = tiles_[static_cast<std::size_t>(t)];
            if (!held.checked_vertices.empty()) {
                const std::size_t before = held.checked_vertices.size() / sizeof(GpuVertex);
                for (std::uint32_t i = 0; i < count; ++i)
                    if (i >= before ||
                        std::memcmp(
                            readback_.data() + std::size_t{i} * sizeof(GpuVertex),
                            held.checked_vertices.data() + std::size_t{i} * sizeof(GpuVertex),
                            sizeof(GpuVertex)) != 0)
                        r.changed_vertex_bytes += sizeof(GpuVertex);
            }
            held.checked_vertices.assign(readback_.begin(), readback_.end());
            // the buffer holds what was sent
            for (std::uint32_t i = 0; i < count; ++i) {
                GpuVertex sent = tb.shadow[i];
                sent.z = tb.drawn_z[i];
                GpuVertex got;
                std::memcpy(&got, readback_.data() + std::size_t{i} * sizeof got, sizeof got);
                if (!sameBits(sent, got)) {
                    if (r.vertex_mismatches == 0)
                        note(
                            tile + " vertex " + std::to_string(i) + ": buffer " + vertexText(got) +
                            ", sent " + vertexText(sent));
                    ++r.vertex_mismatches;
                }
            }
        }
        if (!tb.has_indices)
            continue;
        const std::span<const std::uint32_t> list = source.indices(t);
        const auto list_slots = static_cast<std::uint32_t>(list.size() / 3);
        const std::uint64_t n = std::uint64_t{tb.slots} * 3;
        if (!readBack(tb.index_buffer, n * sizeof(std::uint32_t))) {
            ++r.short_buffers;
            note(tile + ": index buffer smaller than its " + std::to_string(tb.slots) + " slots");
            continue;
        }
        r.indices += n;
        {
            TileBuffers& held = tiles_[static_cast<std::size_t>(t)];
            if (!held.checked_indices.empty()) {
                constexpr std::size_t kPageBytes =
                    roam::TileMesh::kSlotsPerPage * roam::TileMesh::kIndexBytesPerTriangle;
                for (std::size_t at = 0; at < readback_.size(); at += kPageBytes) {
                    const std::size_t bytes = std::min(kPageBytes, readback_.size() - at);
                    const bool differs =
                        at + bytes > held.checked_indices.size() ||
                        std::memcmp(
                            readback_.data() + at, held.checked_indices.data() + at, bytes) != 0;
                    if (differs)
                        r.changed_index_bytes += bytes;
                }
            }
            held.checked_indices.assign(readback_.begin(), readback_.end());
        }
        if (list_slots != tb.slots) {
            ++r.index_mismatches;
            note(
                tile + ": " + std::to_string(tb.slots) + " slots drawn, the list has " +
                std::to_string(list_slots));
        }
        referenced_.assign(count, 0);
        for (std::uint64_t i = 0; i < n; ++i) {
            std::uint32_t got = 0;
            std::memcpy(&got, readback_.data() + i * sizeof got, sizeof got);
            const bool listed = i < list.size() && list[i] == got;
            if (!listed || (tb.has_vertices && got >= count)) {
                if (r.index_mismatches == 0)
                    note(
                        tile + " index " + std::to_string(i) + ": buffer " + std::to_string(got) +
                        ", list " + (i < list.size() ? std::to_string(list[i]) : "none") + ", " +
                        std::to_string(count) + " vertices");
                ++r.index_mismatches;
            } else if (got < count) {
                referenced_[got] = 1;
            }
        }
        if (!tb.has_vertices)
            continue;
        // what the indices refer to is the tessellator's vertex, fresh
        const bool normals = t == normals_tile;
        expected_vertices_.resize(count);
        if (normals)
            source.vertices(t, 0, expected_vertices_);
        else
            source.positions(t, 0, expected_vertices_);
        for (std::uint32_t i = 0; i < count; ++i) {
            if (referenced_[i] == 0)
                continue;
            // the renderer's copy holds the true heights (the buffer's may be morph()'s)
            GpuVertex want = expected_vertices_[i];
            const GpuVertex& held = tb.shadow[i];
            if (!normals)
                want.normal = held.normal;
            if (!sameBits(want, held)) {
                if (r.vertex_mismatches == 0)
                    note(
                        tile + " vertex " + std::to_string(i) + ": sent " + vertexText(held) +
                        ", fresh " + vertexText(expected_vertices_[i]));
                ++r.vertex_mismatches;
            }
        }
    }
}

} // namespace terrain::render
