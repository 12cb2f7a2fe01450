#include "tile_source.h"
#include "upload_runs.h"

#include <terrain/render/terrain_program.h>
#include <terrain/render/terrain_renderer.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <tuple>

namespace terrain::render {

namespace {
static_assert(sizeof(GpuVertex) == 16);
constexpr GLsizei kVertexStride = sizeof(GpuVertex);

// Uploads bridge a gap of this many unchanged vertices between two changed runs: one GPU copy
// instead of two, at most this many vertices sent for nothing (a crater's vertex bytes stay
// within 3x of what it changed).
constexpr std::uint32_t kVertexRunGap = 2;
constexpr std::uint32_t kIndexBytesPerSlot = roam::TileMesh::kIndexBytesPerTriangle;
// The poison a validating renderer fills new buffers with: NaN floats, indices far past any
// vertex array.
constexpr unsigned char kPoisonByte = 0xff;

const void* byteOffset(std::size_t bytes) {
    return reinterpret_cast<const void*>(bytes); // GL's buffer offsets are pointers by API
}

std::uint64_t vertexBytes(std::uint64_t count) {
    return count * sizeof(GpuVertex);
}
} // namespace

Result<std::unique_ptr<TerrainRenderer>>
TerrainRenderer::create(const GlContext& context, const RendererOptions& options) {
    context.makeCurrent();
    std::unique_ptr<TerrainRenderer> r(new TerrainRenderer(context, options));
    Result<TerrainProgram> program = TerrainProgram::build(r->gl_);
    if (!program)
        return program.error();
    r->program_ = std::make_unique<TerrainProgram>(*program);
    r->ring_ = std::make_unique<UploadRing>(r->gl_, options.upload, options.ring_bytes);
    return r;
}

TerrainRenderer::TerrainRenderer(const GlContext& context, const RendererOptions& options)
    : context_(context), gl_(context.gl()), options_(options),
      builder_(std::make_unique<roam::TileVertexBuilder>()) {}

TerrainRenderer::~TerrainRenderer() {
    context_.makeCurrent(); // the names belong to this context
    releaseTiles();
    if (ring_ != nullptr) {
        ring_->flush(); // deletes buffers it was handed
        ring_->release();
    }
    if (program_ != nullptr)
        program_->destroy(gl_);
}

void TerrainRenderer::release(TileBuffers& tb) {
    if (tb.vao == 0)
        return;
    gl_.DeleteVertexArrays(1, &tb.vao);
    gl_.DeleteBuffers(1, &tb.vertex_buffer);
    gl_.DeleteBuffers(1, &tb.index_buffer);
    tb.vao = 0;
    tb.vertex_buffer = 0;
    tb.index_buffer = 0;
}

void TerrainRenderer::releaseTiles() {
    for (TileBuffers& tb : tiles_)
        release(tb);
    tiles_.clear();
}

std::uint64_t TerrainRenderer::gpuBytes() const {
    std::uint64_t bytes = 0;
    for (const TileBuffers& tb : tiles_)
        bytes += vertexBytes(tb.vertex_capacity) +
                 std::uint64_t{tb.index_capacity_slots} * kIndexBytesPerSlot;
    return bytes;
}

unsigned TerrainRenderer::createBuffer(std::uint64_t bytes) {
    // GL_COPY_WRITE_BUFFER: a binding no vertex array records
    unsigned buffer = 0;
    gl_.GenBuffers(1, &buffer);
    gl_.BindBuffer(GL_COPY_WRITE_BUFFER, buffer);
    const void* contents = nullptr;
    if (options_.validate) {
        if (poison_.size() < bytes)
            poison_.assign(bytes, kPoisonByte);
        contents = poison_.data();
    }
    // written only by the GPU's copies, drawn from many times
    gl_.BufferData(GL_COPY_WRITE_BUFFER, static_cast<GLsizeiptr>(bytes), contents, GL_STATIC_DRAW);
    return buffer;
}

UploadStats TerrainRenderer::sync(roam::Tessellator& tess, const Terrain& terrain) {
    TessellatorTiles source(tess, terrain, *builder_);
    builder_->newFrame();
    const UploadStats stats = syncTiles(source);
    synced_terrain_ = &terrain;
    if (options_.validate)
        validate(source);
    return stats;
}

UploadStats TerrainRenderer::sync(roam::DrawnMesh& mesh) {
    DrawnTiles source(mesh);
    const UploadStats stats = syncTiles(source);
    synced_terrain_ = nullptr;
    if (options_.validate)
        validate(source);
    return stats;
}

UploadStats TerrainRenderer::syncTiles(TileSource& source) {
    context_.makeCurrent();
    UploadStats stats;
    if (!have_spec_ || !(source.spec() == spec_) ||
        tiles_.size() != static_cast<std::size_t>(source.tileCount())) {
        // a new world: every buffer is rebuilt
        releaseTiles();
        spec_ = source.spec();
        have_spec_ = true;
        // colours follow the world's first heights (its samples, whichever tiles are loaded):
        // a crater must not recolour the whole map
        std::tie(height_lo_, height_hi_) = source.heightRange();
        tiles_.resize(static_cast<std::size_t>(source.tileCount()));
    }
    ++frame_;
    for (std::int32_t t = 0; t < source.tileCount(); ++t) {
        TileBuffers& tb = tiles_[static_cast<std::size_t>(t)];
        // residency: buffers (and their CPU copy) for tiles in view or seen lately; a tile out
        // of view for longer gives them back and loads in full when it is seen again
        if (source.visible(t)) {
            tb.last_visible = frame_;
            tb.seen = true;
        }
        if (!tb.seen || frame_ - tb.last_visible > evict_after_frames_) {
            if (tb.vao != 0)
                evict(tb, stats);
            continue;
        }
        if (tb.vao == 0) {
            gl_.GenVertexArrays(1, &tb.vao);
            ++stats.loaded_tiles;
        }
        const std::uint64_t before = stats.bytes();
        const bool loading = !tb.has_vertices;
        if (!tb.has_vertices || source.verticesAllChanged(t) || !source.vertexChanges(t).empty())
            uploadVertices(source, t, tb, stats);
        // a version moved with nothing marked (a grain gone, a chunk moved) leaves the buffer
        // as current as one rebuilt
        tb.vertex_version = source.vertexVersion(t);
        // a renderer that joins a running tessellator loads every list once
        if (source.indicesDirty(t) || !tb.has_indices)
            uploadIndices(source, t, tb, stats);
        if (loading)
            stats.load_bytes += stats.bytes() - before;
    }
    ring_->flush();
    gl_.BindVertexArray(0);
    totals_.vertex_bytes += stats.vertex_bytes;
    totals_.index_bytes += stats.index_bytes;
    totals_.vertex_tiles += stats.vertex_tiles;
    totals_.index_tiles += stats.index_tiles;
    totals_.index_uploads += stats.index_uploads;
    totals_.vertex_uploads += stats.vertex_uploads;
    totals_.evicted_tiles += stats.evicted_tiles;
    totals_.loaded_tiles += stats.loaded_tiles;
    totals_.load_bytes += stats.load_bytes;
    totals_.grown_buffers += stats.grown_buffers;
    totals_.moved_bytes += stats.moved_bytes;
    return stats;
}

void TerrainRenderer::evict(TileBuffers& tb, UploadStats& stats) {
    // deleted now: the GL keeps the storage until the draws that read it are done
    release(tb);
    std::vector<GpuVertex>().swap(tb.shadow);
    std::vector<float>().swap(tb.drawn_z);
    std::vector<unsigned char>().swap(tb.checked_vertices);
    std::vector<unsigned char>().swap(tb.checked_indices);
    tb.morphed = false;
    tb.has_vertices = false;
    tb.has_indices = false;
    tb.vertex_capacity = 0;
    tb.index_capacity_slots = 0;
    tb.slots = 0;
    ++stats.evicted_tiles;
}

std::uint32_t TerrainRenderer::residentTiles() const {
    std::uint32_t n = 0;
    for (const TileBuffers& tb : tiles_)
        n += tb.has_vertices ? 1 : 0;
    return n;
}

std::uint64_t TerrainRenderer::shadowBytes() const {
    std::uint64_t bytes = 0;
    for (const TileBuffers& tb : tiles_)
        bytes += vertexBytes(tb.shadow.capacity()) +
                 std::uint64_t{tb.drawn_z.capacity()} * sizeof(float);
    return bytes;
}

void TerrainRenderer::attachVertexBuffer(const TileBuffers& tb) {
    // the attribute formats and the buffer are recorded in the tile's vertex array
    gl_.BindVertexArray(tb.vao);
    gl_.BindBuffer(GL_ARRAY_BUFFER, tb.vertex_buffer);
    gl_.EnableVertexAttribArray(0);
    gl_.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, kVertexStride, byteOffset(0));
    gl_.EnableVertexAttribArray(1);
    gl_.VertexAttribPointer(
        1, 4, GL_INT_2_10_10_10_REV, GL_TRUE, kVertexStride, byteOffset(3 * sizeof(float)));
    gl_.BindVertexArray(0);
}

void TerrainRenderer::uploadVertices(
    TileSource& source, std::int32_t tile, TileBuffers& tb, UploadStats& stats) {
    const std::uint32_t count = source.vertexCount(tile);
    const auto old_count = static_cast<std::uint32_t>(tb.shadow.size());
    // what to build: everything for a tile loaded (or reset), else the ranges the tessellator
    // marked, sorted and joined
    scratch_ranges_.clear();
    if (!tb.has_vertices || source.verticesAllChanged(tile)) {
        scratch_ranges_.push_back({0, count});
    } else {
        for (const roam::VertexRange& r : source.vertexChanges(tile))
            scratch_ranges_.push_back({r.begin, std::min(r.end, count)});
        if (count > old_count) // the array only grows between resets: new grains, marked too
            scratch_ranges_.push_back({old_count, count});
        std::sort(
            scratch_ranges_.begin(), scratch_ranges_.end(),
            [](const roam::VertexRange& a, const roam::VertexRange& b) {
                return a.begin < b.begin;
            });
        std::size_t kept = 0;
        for (const roam::VertexRange& r : scratch_ranges_) {
            if (r.begin >= r.end)
                continue;
            if (kept > 0 && r.begin <= scratch_ranges_[kept - 1].end)
                scratch_ranges_[kept - 1].end = std::max(scratch_ranges_[kept - 1].end, r.end);
            else
                scratch_ranges_[kept++] = r;
        }
        scratch_ranges_.resize(kept);
    }
    source.takeVertexChanges(tile);

    if (!tb.has_vertices) {
        tb.vertex_capacity = count; // exactly: most tiles never gain a block
        tb.vertex_buffer = createBuffer(vertexBytes(count));
        attachVertexBuffer(tb);
    } else if (count > tb.vertex_capacity) {
        // a bigger buffer, the old contents moved into it by the GPU, so that only what changed
        // is uploaded; a quarter to spare, as a tile gains blocks crater by crater
        tb.vertex_capacity = count + count / 4;
        const unsigned grown = createBuffer(vertexBytes(tb.vertex_capacity));
        const std::uint64_t kept = vertexBytes(std::min(old_count, count));
        ring_->moveBuffer(tb.vertex_buffer, grown, kept);
        tb.vertex_buffer = grown;
        attachVertexBuffer(tb);
        ++stats.grown_buffers;
        stats.moved_bytes += kept;
    }
    // only a reset shrinks the array; what lies past its end is never drawn
    tb.shadow.resize(count);
    tb.drawn_z.resize(count);
    const std::uint32_t known = std::min(old_count, count);
    scratch_runs_.clear();
    for (const roam::VertexRange& r : scratch_ranges_) {
        const std::uint32_t n = r.end - r.begin;
        scratch_vertices_.resize(n);
        source.vertices(tile, r.begin, scratch_vertices_);
        // send what differs from the buffer's contents; what the buffer draws is the true
        // height where this sends, the morphed one elsewhere (a bridged gap sends its drawn
        // height again)
        scratch_send_.resize(n);
        for (std::uint32_t k = 0; k < n; ++k) {
            const std::uint32_t i = r.begin + k;
            const bool send =
                i >= known ||
                std::memcmp(&scratch_vertices_[k], &tb.shadow[i], sizeof(GpuVertex)) != 0;
            scratch_send_[k] = send ? 1 : 0;
            if (send) {
                tb.drawn_z[i] = scratch_vertices_[k].z;
                tb.shadow[i] = scratch_vertices_[k];
            }
        }
        collectRuns(r.begin, n, [&](std::uint32_t k) { return scratch_send_[k] != 0; });
    }
    const std::uint64_t bytes = stageVertexRuns(tb, stats);
    if (tb.shadow.capacity() > tb.shadow.size() + tb.shadow.size() / 2)
        tb.shadow.shrink_to_fit();
    tb.has_vertices = true;
    stats.vertex_bytes += bytes;
    if (bytes > 0)
        ++stats.vertex_tiles;
}

template <class Differs>
void TerrainRenderer::collectRuns(std::uint32_t first, std::uint32_t count, Differs&& differs) {
    // element first + k differs where differs(k); a run bridges gaps of up to kVertexRunGap
    std::uint32_t k = 0;
    while (k < count) {
        if (!differs(k)) {
            ++k;
            continue;
        }
        UploadRun run{first + k, first + k + 1, 1};
        for (++k; k < count && first + k - run.end <= kVertexRunGap; ++k)
            if (differs(k)) {
                run.end = first + k + 1;
                ++run.changed;
            }
        scratch_runs_.push_back(run);
        k = run.end - first;
    }
}

std::uint64_t TerrainRenderer::stageVertexRuns(const TileBuffers& tb, UploadStats& stats) {
    // the buffer's copy of a vertex is the shadow with its drawn height
    joinRuns(scratch_runs_);
    std::uint64_t bytes = 0;
    for (const UploadRun& r : scratch_runs_) {
        scratch_staged_.assign(tb.shadow.begin() + r.begin, tb.shadow.begin() + r.end);
        for (std::uint32_t m = r.begin; m < r.end; ++m)
            scratch_staged_[m - r.begin].z = tb.drawn_z[m];
        const std::uint64_t run = vertexBytes(r.end - r.begin);
        ring_->stage(tb.vertex_buffer, vertexBytes(r.begin), scratch_staged_.data(), run);
        bytes += run;
        ++stats.vertex_uploads;
    }
    scratch_runs_.clear();
    return bytes;
}

UploadStats TerrainRenderer::morph(const roam::Tessellator& tess, const roam::Camera& camera) {
    // off, it still restores the true heights of tiles it moved while on
    UploadStats stats;
    if (!have_spec_)
        return stats;
    context_.makeCurrent();
    const bool on = geomorph_ > 0.0;
    const roam::ViewMetric view(camera);
    const double full = on ? tess.threshold() / geomorph_ : 0.0;
    for (std::int32_t t = 0; t < tess.tileCount(); ++t) {
        TileBuffers& tb = tiles_[static_cast<std::size_t>(t)];
        if (!tb.has_vertices || tb.vertex_version != tess.tileVertexVersion(t) ||
            tb.shadow.size() != static_cast<std::size_t>(tess.tileVertexCount(t)))
            continue; // not synced with this mesh
        const auto count = static_cast<std::uint32_t>(tb.shadow.size());
        if (on && tess.tileVisible(t)) {
            // vertices the mesh does not use keep what the buffer has
            scratch_heights_.assign(tb.drawn_z.begin(), tb.drawn_z.end());
            tess.morphedHeights(t, view, full, scratch_heights_);
        } else if (!on && tb.morphed) {
            // turned off: back to the true heights
            scratch_heights_.resize(count);
            for (std::uint32_t i = 0; i < count; ++i)
                scratch_heights_[i] = tb.shadow[i].z;
        } else {
            continue;
        }
        tb.morphed = on;
        scratch_send_.resize(count);
        bool any = false;
        for (std::uint32_t i = 0; i < count; ++i) {
            const auto z = static_cast<float>(scratch_heights_[i]);
            scratch_send_[i] = z != tb.drawn_z[i] ? 1 : 0;
            any = any || scratch_send_[i] != 0;
            tb.drawn_z[i] = z;
        }
        if (!any)
            continue;
        collectRuns(0, count, [&](std::uint32_t i) { return scratch_send_[i] != 0; });
        stats.vertex_bytes += stageVertexRuns(tb, stats);
        ++stats.vertex_tiles;
    }
    ring_->flush();
    totals_.vertex_bytes += stats.vertex_bytes;
    totals_.vertex_tiles += stats.vertex_tiles;
    totals_.vertex_uploads += stats.vertex_uploads;
    if (options_.validate && stats.vertex_bytes > 0 && synced_terrain_ != nullptr)
        validate(TessellatorTiles(tess, *synced_terrain_, *builder_));
    return stats;
}

void TerrainRenderer::uploadIndices(
    TileSource& source, std::int32_t tile, TileBuffers& tb, UploadStats& stats) {
    const std::span<const std::uint32_t> list = source.indices(tile);
    const auto slots = static_cast<std::uint32_t>(list.size() / 3);
    const std::uint32_t* indices = list.data();
    std::uint64_t bytes = 0;
    const bool whole = source.indicesRewritten(tile) || !tb.has_indices;
    if (slots > tb.index_capacity_slots || !tb.has_indices) {
        // grown by half again, so that a growing list is not moved every frame
        const std::uint64_t grown = std::uint64_t{tb.index_capacity_slots} * 3 / 2;
        const auto capacity =
            static_cast<std::uint32_t>(std::max<std::uint64_t>({slots, grown, 64u}));
        const unsigned buffer = createBuffer(std::uint64_t{capacity} * kIndexBytesPerSlot);
        if (tb.index_buffer != 0) {
            // what the buffer held and still stands moves with it (a rewrite sends it all)
            const std::uint64_t kept =
                whole ? 0 : std::uint64_t{std::min(tb.slots, slots)} * kIndexBytesPerSlot;
            ring_->moveBuffer(tb.index_buffer, buffer, kept);
            ++stats.grown_buffers;
            stats.moved_bytes += kept;
        }
        tb.index_buffer = buffer;
        tb.index_capacity_slots = capacity;
        // the element buffer binding belongs to the vertex array
        gl_.BindVertexArray(tb.vao);
        gl_.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, tb.index_buffer);
        gl_.BindVertexArray(0);
    }
    if (whole) {
        bytes = std::uint64_t{slots} * kIndexBytesPerSlot;
        if (slots > 0) {
            ring_->stage(tb.index_buffer, 0, indices, bytes);
            ++stats.index_uploads;
        }
    } else {
        // runs of dirty pages (UploadRun: joined while at most half clean), one GPU copy each
        const std::span<const std::uint32_t> pages_written = source.dirtyPages(tile);
        scratch_pages_.assign(pages_written.begin(), pages_written.end());
        std::sort(scratch_pages_.begin(), scratch_pages_.end());
        constexpr std::uint32_t kPage = roam::TileMesh::kSlotsPerPage;
        const std::uint32_t pages = (slots + kPage - 1) / kPage;
        scratch_runs_.clear();
        for (const std::uint32_t page : scratch_pages_) {
            if (page >= pages)
                break; // cut off with the end of the list
            if (!scratch_runs_.empty() && scratch_runs_.back().end == page) {
                ++scratch_runs_.back().end;
                ++scratch_runs_.back().changed;
            } else {
                scratch_runs_.push_back({page, page + 1, 1});
            }
        }
        joinRuns(scratch_runs_);
        for (const UploadRun& r : scratch_runs_) {
            const std::uint32_t first = r.begin * kPage;
            const std::uint32_t last = std::min(slots, r.end * kPage);
            const std::uint64_t run = std::uint64_t{last - first} * kIndexBytesPerSlot;
            ring_->stage(
                tb.index_buffer, std::uint64_t{first} * kIndexBytesPerSlot,
                indices + std::size_t{first} * 3, run);
            bytes += run;
            ++stats.index_uploads;
        }
        scratch_runs_.clear();
    }
    source.takeIndexChanges(tile);
    tb.has_indices = true;
    tb.slots = slots;
    stats.index_bytes += bytes;
    ++stats.index_tiles;
}

DrawStats TerrainRenderer::draw(
    const roam::Tessellator& tess, const roam::Camera& camera, const RenderOptions& options) {
    return drawFrame(
        tess.tileCount(), [&](std::int32_t t) { return tess.tileVisible(t); },
        [&](std::int32_t t) { return tess.tileMesh(t).triangleCount(); }, camera, options);
}

DrawStats TerrainRenderer::draw(
    const roam::DrawnMesh& mesh, const roam::Camera& camera, const RenderOptions& options) {
    return drawFrame(
        mesh.tileCount(), [&](std::int32_t t) { return mesh.tileVisible(t); },
        [&](std::int32_t t) { return mesh.slotCount(t); }, camera, options);
}

template <class Visible, class Triangles>
DrawStats TerrainRenderer::drawFrame(
    std::int32_t tiles,
    Visible&& visible,
    Triangles&& triangles,
    const roam::Camera& camera,
    const RenderOptions& options) {
    context_.makeCurrent();
    DrawStats stats;
    const GlApi& gl = gl_;
    gl.Viewport(0, 0, context_.width(), context_.height());
    gl.ClearColor(options.sky.x, options.sky.y, options.sky.z, 1.0f);
    gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    if (tiles_.empty() || tiles_.size() != static_cast<std::size_t>(tiles))
        return stats; // nothing synced, or not from this source
    program_->beginFrame(gl, camera, spec_, height_lo_, height_hi_, options);

    if (options.mode == DrawMode::kWireframe) {
        gl.PolygonMode(GL_FRONT_AND_BACK, GL_LINE);
        drawTiles(tiles, visible, triangles, stats);
    } else {
        gl.PolygonMode(GL_FRONT_AND_BACK, GL_FILL);
        if (options.mode == DrawMode::kShadedWireframe) {
            // push the fill back so the lines drawn over it win the depth test
            gl.Enable(GL_POLYGON_OFFSET_FILL);
            gl.PolygonOffset(1.0f, 1.0f);
        }
        drawTiles(tiles, visible, triangles, stats);
        if (options.mode == DrawMode::kShadedWireframe) {
            gl.Disable(GL_POLYGON_OFFSET_FILL);
            gl.PolygonMode(GL_FRONT_AND_BACK, GL_LINE);
            program_->setLineColour(gl, 0.05f, 0.05f, 0.08f, 0.6f);
            DrawStats lines;
            drawTiles(tiles, visible, triangles, lines);
        }
    }
    gl.PolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    gl.BindVertexArray(0);
    program_->endFrame(gl);
    return stats;
}

template <class Visible, class Triangles>
void TerrainRenderer::drawTiles(
    std::int32_t tiles, Visible& visible, Triangles& triangles, DrawStats& stats) {
    // nothing per draw but the tile's vertex array: every tile is drawn with the frame's
    // uniforms, so shared vertices transform to the same bits (watertight)
    for (std::int32_t t = 0; t < tiles; ++t) {
        const TileBuffers& tb = tiles_[static_cast<std::size_t>(t)];
        if (tb.slots == 0 || !visible(t))
            continue;
        gl_.BindVertexArray(tb.vao);
        // every slot: freed ones hold degenerate triangles, which draw nothing
        gl_.DrawElements(
            GL_TRIANGLES, static_cast<GLsizei>(tb.slots * 3), GL_UNSIGNED_INT, nullptr);
        ++stats.tiles;
        stats.triangles += triangles(t);
    }
}

} // namespace terrain::render
