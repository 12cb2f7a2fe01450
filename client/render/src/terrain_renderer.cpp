#include <terrain/render/terrain_program.h>
#include <terrain/render/terrain_renderer.h>
#include <terrain/surface_query.h>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <tuple>

namespace terrain::render {

namespace {
static_assert(sizeof(GpuVertex) == 16);
constexpr GLsizei kVertexStride = sizeof(GpuVertex);

std::uint32_t packNormal(double nx, double ny, double nz) {
    const auto component = [](double v, int shift) {
        const auto q = static_cast<std::int32_t>(std::lround(std::clamp(v, -1.0, 1.0) * 511.0));
        return (static_cast<std::uint32_t>(q) & 0x3ffu) << shift;
    };
    return component(nx, 0) | component(ny, 10) | component(nz, 20);
}

// Uploads are split where this many unchanged vertices separate two changed runs.
constexpr std::uint32_t kVertexRunGap = 64;
constexpr std::uint32_t kIndexBytesPerSlot = roam::TileMesh::kIndexBytesPerTriangle;

const void* byteOffset(std::size_t bytes) {
    return reinterpret_cast<const void*>(bytes); // GL's buffer offsets are pointers by API
}

GLsizeiptr sizeOf(std::uint64_t bytes) {
    return static_cast<GLsizeiptr>(bytes);
}
} // namespace

Result<std::unique_ptr<TerrainRenderer>> TerrainRenderer::create(const GlContext& context) {
    context.makeCurrent();
    std::unique_ptr<TerrainRenderer> r(new TerrainRenderer(context));
    Result<TerrainProgram> program = TerrainProgram::build(r->gl_);
    if (!program)
        return program.error();
    r->program_ = std::make_unique<TerrainProgram>(*program);
    return r;
}

TerrainRenderer::TerrainRenderer(const GlContext& context) : context_(context), gl_(context.gl()) {}

TerrainRenderer::~TerrainRenderer() {
    context_.makeCurrent(); // the names belong to this context
    releaseTiles();
    if (program_ != nullptr)
        program_->destroy(gl_);
}

void TerrainRenderer::releaseTiles() {
    for (TileBuffers& tb : tiles_) {
        gl_.DeleteVertexArrays(1, &tb.vao);
        gl_.DeleteBuffers(1, &tb.vertex_buffer);
        gl_.DeleteBuffers(1, &tb.index_buffer);
    }
    tiles_.clear();
}

std::uint64_t TerrainRenderer::gpuBytes() const {
    std::uint64_t bytes = 0;
    for (const TileBuffers& tb : tiles_)
        bytes += std::uint64_t{tb.vertex_capacity} * sizeof(GpuVertex) +
                 std::uint64_t{tb.index_capacity_slots} * kIndexBytesPerSlot;
    return bytes;
}

UploadStats TerrainRenderer::sync(roam::Tessellator& tess, const Terrain& terrain) {
    context_.makeCurrent();
    UploadStats stats;
    if (!have_spec_ || !(terrain.spec() == spec_) ||
        tiles_.size() != static_cast<std::size_t>(tess.tileCount())) {
        // a new world: every buffer is rebuilt
        releaseTiles();
        spec_ = terrain.spec();
        have_spec_ = true;
        // colours follow the world's first heights (its samples, whichever tiles are loaded):
        // a crater must not recolour the whole map
        std::tie(height_lo_, height_hi_) = TerrainProgram::heightRange(terrain);
        tiles_.resize(static_cast<std::size_t>(tess.tileCount()));
        for (TileBuffers& tb : tiles_) {
            gl_.GenVertexArrays(1, &tb.vao);
            gl_.GenBuffers(1, &tb.vertex_buffer);
            gl_.GenBuffers(1, &tb.index_buffer);
            gl_.BindVertexArray(tb.vao);
            attachVertexBuffer(tb);
            gl_.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, tb.index_buffer); // recorded in the VAO
        }
        gl_.BindVertexArray(0);
    }
    ++frame_;
    for (std::int32_t t = 0; t < tess.tileCount(); ++t) {
        TileBuffers& tb = tiles_[static_cast<std::size_t>(t)];
        // residency: buffers (and their CPU copy) for tiles in view or seen lately; a tile out
        // of view for longer gives them back and loads in full when it is seen again
        if (tess.tileVisible(t)) {
            tb.last_visible = frame_;
            tb.seen = true;
        }
        if (!tb.seen || frame_ - tb.last_visible > evict_after_frames_) {
            if (tb.has_vertices || tb.has_indices)
                evict(tb, stats);
            continue;
        }
        if (!tb.has_vertices || tb.vertex_version != tess.tileVertexVersion(t) ||
            surfaceChangedIn(t))
            uploadVertices(tess, terrain, t, tb, stats);
        roam::TileMesh& mesh = tess.tileMesh(t);
        // a renderer that joins a running tessellator loads every list once
        if (mesh.dirty() || !tb.has_indices)
            uploadIndices(mesh, tb, stats);
        tb.triangles = mesh.triangleCount();
    }
    gl_.BindVertexArray(0);
    changed_.clear();
    all_changed_ = false;
    totals_.vertex_bytes += stats.vertex_bytes;
    totals_.index_bytes += stats.index_bytes;
    totals_.vertex_tiles += stats.vertex_tiles;
    totals_.index_tiles += stats.index_tiles;
    totals_.index_uploads += stats.index_uploads;
    totals_.evicted_tiles += stats.evicted_tiles;
    return stats;
}

void TerrainRenderer::evict(TileBuffers& tb, UploadStats& stats) {
    // the names and the VAO stay (a few bytes); the storage goes
    gl_.BindVertexArray(0);
    gl_.BindBuffer(GL_ARRAY_BUFFER, tb.vertex_buffer);
    gl_.BufferData(GL_ARRAY_BUFFER, 0, nullptr, GL_STATIC_DRAW);
    gl_.BindVertexArray(tb.vao); // the element buffer binding belongs to the VAO
    gl_.BufferData(GL_ELEMENT_ARRAY_BUFFER, 0, nullptr, GL_DYNAMIC_DRAW);
    gl_.BindVertexArray(0);
    std::vector<GpuVertex>().swap(tb.shadow);
    std::vector<float>().swap(tb.drawn_z);
    tb.morphed = false;
    tb.has_vertices = false;
    tb.has_indices = false;
    tb.vertex_capacity = 0;
    tb.index_capacity_slots = 0;
    tb.triangles = 0;
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
        bytes += std::uint64_t{tb.shadow.capacity()} * sizeof(GpuVertex) +
                 std::uint64_t{tb.drawn_z.capacity()} * sizeof(float);
    return bytes;
}

void TerrainRenderer::surfaceChanged(std::span<const CellRect> cells, bool all) {
    all_changed_ = all_changed_ || all;
    // normals sample the surface up to one cell away: widen by a cell
    for (const CellRect& c : cells)
        if (!c.empty())
            changed_.push_back(Region{
                {(c.x0 - 1) * roam::kLatticePerCell, (c.y0 - 1) * roam::kLatticePerCell},
                {(c.x1 + 2) * roam::kLatticePerCell, (c.y1 + 2) * roam::kLatticePerCell}});
}

bool TerrainRenderer::surfaceChangedIn(std::int32_t tile) const {
    if (all_changed_)
        return true;
    const std::int32_t x0 = (tile % spec_.tilesX()) * roam::kLatticePerTile;
    const std::int32_t y0 = (tile / spec_.tilesX()) * roam::kLatticePerTile;
    const Region t{{x0, y0}, {x0 + roam::kLatticePerTile, y0 + roam::kLatticePerTile}};
    for (const Region& r : changed_)
        if (r.lo.x <= t.hi.x && t.lo.x <= r.hi.x && r.lo.y <= t.hi.y && t.lo.y <= r.hi.y)
            return true;
    return false;
}

void TerrainRenderer::attachVertexBuffer(const TileBuffers& tb) {
    // the VAO must be bound: the attribute formats and the buffer are recorded in it
    gl_.BindBuffer(GL_ARRAY_BUFFER, tb.vertex_buffer);
    gl_.EnableVertexAttribArray(0);
    gl_.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, kVertexStride, byteOffset(0));
    gl_.EnableVertexAttribArray(1);
    gl_.VertexAttribPointer(
        1, 4, GL_INT_2_10_10_10_REV, GL_TRUE, kVertexStride, byteOffset(3 * sizeof(float)));
}

void TerrainRenderer::growVertexBuffer(TileBuffers& tb, std::uint32_t count) {
    // a bigger buffer with the old contents copied on the GPU, so that only what changed is
    // uploaded; a quarter to spare, as a tile gains blocks crater by crater
    const std::uint32_t capacity = count + count / 4;
    GLuint grown = 0;
    gl_.GenBuffers(1, &grown);
    gl_.BindBuffer(GL_COPY_WRITE_BUFFER, grown);
    gl_.BufferData(
        GL_COPY_WRITE_BUFFER, sizeOf(std::uint64_t{capacity} * sizeof(GpuVertex)), nullptr,
        GL_STATIC_DRAW);
    gl_.BindBuffer(GL_COPY_READ_BUFFER, tb.vertex_buffer);
    gl_.CopyBufferSubData(
        GL_COPY_READ_BUFFER, GL_COPY_WRITE_BUFFER, 0, 0,
        sizeOf(std::uint64_t{tb.shadow.size()} * sizeof(GpuVertex)));
    gl_.DeleteBuffers(1, &tb.vertex_buffer);
    tb.vertex_buffer = grown;
    tb.vertex_capacity = capacity;
    gl_.BindVertexArray(tb.vao);
    attachVertexBuffer(tb);
    gl_.BindVertexArray(0);
}

void TerrainRenderer::uploadVertices(
    roam::Tessellator& tess,
    const Terrain& terrain,
    std::int32_t tile,
    TileBuffers& tb,
    UploadStats& stats) {
    const double spacing = spec_.spacingMetres();
    const double per_lattice = tess.metresPerLattice();
    const double per_fine = tess.metresPerFineUnit();
    const double corner_x = (tile % spec_.tilesX()) * kTileCells * spacing;
    const double corner_y = (tile / spec_.tilesX()) * kTileCells * spacing;
    const auto count = static_cast<std::uint32_t>(tess.tileVertexCount(tile));
    if (tb.has_vertices && count > tb.vertex_capacity)
        growVertexBuffer(tb, count);
    const bool full = !tb.has_vertices || all_changed_;
    const auto old_count = full ? 0u : static_cast<std::uint32_t>(tb.shadow.size());

    // Positions first (cheap). A vertex new to its slot (a grain came, or took a hole) needs
    // its own normal. Where one rose or fell in place, the surface changed, and so may every
    // normal within one cell of it (the surface changes only where some vertex did: every patch
    // cell has a detail block), as may the normals in surfaceChanged()'s regions.
    scratch_keys_.resize(count);
    scratch_vertices_.resize(count);
    tess.tileVertices(tile, scratch_keys_);
    roam::LatticePoint lo{
        std::numeric_limits<std::int32_t>::max(), std::numeric_limits<std::int32_t>::max()};
    roam::LatticePoint hi{
        std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::min()};
    for (std::uint32_t i = 0; i < count; ++i) {
        const roam::TileVertex& v = scratch_keys_[i];
        GpuVertex& out = scratch_vertices_[i];
        out.x = static_cast<float>(v.position.x * per_lattice - corner_x);
        out.y = static_cast<float>(v.position.y * per_lattice - corner_y);
        out.z = static_cast<float>(static_cast<double>(v.height) * per_fine);
        const bool fresh = i >= old_count || out.x != tb.shadow[i].x || out.y != tb.shadow[i].y;
        const bool moved = !fresh && out.z != tb.shadow[i].z;
        if (moved) {
            lo = {std::min(lo.x, v.position.x), std::min(lo.y, v.position.y)};
            hi = {std::max(hi.x, v.position.x), std::max(hi.y, v.position.y)};
        }
        out.normal = fresh || moved ? 0u : tb.shadow[i].normal;
    }
    constexpr std::int32_t kStencil = roam::kLatticePerCell;
    lo = {lo.x - kStencil, lo.y - kStencil};
    hi = {hi.x + kStencil, hi.y + kStencil};
    const auto needsNormal = [&](std::uint32_t i) {
        const roam::LatticePoint p = scratch_keys_[i].position;
        if (full || i >= old_count || scratch_vertices_[i].normal == 0u ||
            (p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y))
            return true;
        for (const Region& r : changed_)
            if (p.x >= r.lo.x && p.x <= r.hi.x && p.y >= r.lo.y && p.y <= r.hi.y)
                return true;
        return false;
    };
    for (std::uint32_t i = 0; i < count; ++i) {
        if (!needsNormal(i))
            continue;
        const roam::TileVertex& v = scratch_keys_[i];
        const double x = v.position.x * per_lattice;
        const double y = v.position.y * per_lattice;
        // a smooth normal from the true surface: central differences over the vertex's own grid
        // step (a cell on the base grid, a lattice step inside a detail block)
        // (one-sided at the map's edge, where the surface is clamped)
        double dzdx = 0.0;
        double dzdy = 0.0;
        if (i < static_cast<std::uint32_t>(roam::kTileBaseVertices)) {
            // on the base grid the surface at the neighbouring vertices is their sample (patch
            // corners are pinned to them): read the samples, no surface queries; the padding
            // takes the map edge's slope
            const std::int32_t gx = std::min(v.position.x / roam::kLatticePerCell, spec_.width - 1);
            const std::int32_t gy =
                std::min(v.position.y / roam::kLatticePerCell, spec_.height - 1);
            const std::int32_t ax = std::max(gx - 1, 0);
            const std::int32_t bx = std::min(gx + 1, spec_.width - 1);
            const std::int32_t ay = std::max(gy - 1, 0);
            const std::int32_t by = std::min(gy + 1, spec_.height - 1);
            const double unit = spec_.metresPerUnit();
            if (bx > ax)
                dzdx = (terrain.sample(bx, gy) - terrain.sample(ax, gy)) * unit /
                       ((bx - ax) * spacing);
            if (by > ay)
                dzdy = (terrain.sample(gx, by) - terrain.sample(gx, ay)) * unit /
                       ((by - ay) * spacing);
        } else {
            const double step = per_lattice;
            const double x0 = std::max(x - step, 0.0);
            const double x1 = std::min(x + step, spec_.extentX());
            const double y0 = std::max(y - step, 0.0);
            const double y1 = std::min(y + step, spec_.extentY());
            if (x1 > x0)
                dzdx = (surfaceHeight(terrain, x1, y) - surfaceHeight(terrain, x0, y)) / (x1 - x0);
            if (y1 > y0)
                dzdy = (surfaceHeight(terrain, x, y1) - surfaceHeight(terrain, x, y0)) / (y1 - y0);
        }
        const double inv = 1.0 / std::sqrt(dzdx * dzdx + dzdy * dzdy + 1.0);
        scratch_vertices_[i].normal = packNormal(-dzdx * inv, -dzdy * inv, inv);
    }

    // send what differs from the buffer's contents, in runs that bridge short equal gaps
    gl_.BindVertexArray(0);
    gl_.BindBuffer(GL_ARRAY_BUFFER, tb.vertex_buffer);
    if (!tb.has_vertices) {
        tb.vertex_capacity = count; // exactly: most tiles never gain a block
        gl_.BufferData(
            GL_ARRAY_BUFFER, sizeOf(std::uint64_t{count} * sizeof(GpuVertex)), nullptr,
            GL_STATIC_DRAW);
    }
    // what the buffer draws: the true height where this sends, the morphed one elsewhere (a
    // bridged gap sends its drawn height again)
    tb.drawn_z.resize(count);
    scratch_send_.resize(count);
    for (std::uint32_t i = 0; i < count; ++i) {
        const bool send = i >= old_count ||
                          std::memcmp(&scratch_vertices_[i], &tb.shadow[i], sizeof(GpuVertex)) != 0;
        scratch_send_[i] = send ? 1 : 0;
        if (send)
            tb.drawn_z[i] = scratch_vertices_[i].z;
        else
            scratch_vertices_[i].z = tb.drawn_z[i];
    }
    const std::uint64_t bytes =
        sendRuns(count, [&](std::uint32_t i) { return scratch_send_[i] != 0; });
    for (std::uint32_t i = 0; i < count; ++i)
        scratch_vertices_[i].z =
            static_cast<float>(static_cast<double>(scratch_keys_[i].height) * per_fine);
    // the copy keeps this tile's size: swapping would hand the scratch's capacity (the largest
    // tile synced so far) to every tile in turn
    tb.shadow.assign(scratch_vertices_.begin(), scratch_vertices_.end());
    if (tb.shadow.capacity() > tb.shadow.size() + tb.shadow.size() / 2)
        tb.shadow.shrink_to_fit();
    tb.vertex_version = tess.tileVertexVersion(tile);
    tb.has_vertices = true;
    stats.vertex_bytes += bytes;
    if (bytes > 0)
        ++stats.vertex_tiles;
}

template <class Differs>
std::uint64_t TerrainRenderer::sendRuns(std::uint32_t count, Differs&& differs) {
    std::uint64_t bytes = 0;
    std::uint32_t i = 0;
    while (i < count) {
        if (!differs(i)) {
            ++i;
            continue;
        }
        const std::uint32_t first = i;
        std::uint32_t last = i + 1; // one past the last differing vertex
        for (++i; i < count && i - last < kVertexRunGap; ++i)
            if (differs(i))
                last = i + 1;
        const std::uint64_t run = std::uint64_t{last - first} * sizeof(GpuVertex);
        gl_.BufferSubData(
            GL_ARRAY_BUFFER, static_cast<GLintptr>(std::uint64_t{first} * sizeof(GpuVertex)),
            sizeOf(run), scratch_vertices_.data() + first);
        bytes += run;
        i = last;
    }
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
        scratch_vertices_.assign(tb.shadow.begin(), tb.shadow.end());
        scratch_send_.resize(count);
        bool any = false;
        for (std::uint32_t i = 0; i < count; ++i) {
            const auto z = static_cast<float>(scratch_heights_[i]);
            scratch_send_[i] = z != tb.drawn_z[i] ? 1 : 0;
            any = any || scratch_send_[i] != 0;
            tb.drawn_z[i] = z;
            scratch_vertices_[i].z = z;
        }
        if (!any)
            continue;
        gl_.BindVertexArray(0);
        gl_.BindBuffer(GL_ARRAY_BUFFER, tb.vertex_buffer);
        stats.vertex_bytes +=
            sendRuns(count, [&](std::uint32_t i) { return scratch_send_[i] != 0; });
        ++stats.vertex_tiles;
    }
    totals_.vertex_bytes += stats.vertex_bytes;
    totals_.vertex_tiles += stats.vertex_tiles;
    return stats;
}

void TerrainRenderer::uploadIndices(roam::TileMesh& mesh, TileBuffers& tb, UploadStats& stats) {
    const std::uint32_t slots = mesh.slotCount();
    const std::uint32_t* indices = mesh.indices().data();
    // the element buffer binding belongs to the VAO
    gl_.BindVertexArray(tb.vao);
    std::uint64_t bytes = 0;
    if (mesh.rewritten() || !tb.has_indices || slots > tb.index_capacity_slots) {
        // reallocate only to grow (a rewrite reuses the buffer), by half again so a growing list
        // is not reallocated every frame
        if (slots > tb.index_capacity_slots || !tb.has_indices) {
            const std::uint64_t grown = std::uint64_t{tb.index_capacity_slots} * 3 / 2;
            const auto capacity =
                static_cast<std::uint32_t>(std::max<std::uint64_t>({slots, grown, 64u}));
            gl_.BufferData(
                GL_ELEMENT_ARRAY_BUFFER, sizeOf(std::uint64_t{capacity} * kIndexBytesPerSlot),
                nullptr, GL_DYNAMIC_DRAW);
            tb.index_capacity_slots = capacity;
            ++stats.index_uploads;
        }
        bytes = std::uint64_t{slots} * kIndexBytesPerSlot;
        if (slots > 0) {
            gl_.BufferSubData(GL_ELEMENT_ARRAY_BUFFER, 0, sizeOf(bytes), indices);
            ++stats.index_uploads;
        }
    } else {
        // runs of consecutive dirty pages, each one glBufferSubData
        scratch_pages_.assign(mesh.dirtyPages().begin(), mesh.dirtyPages().end());
        std::sort(scratch_pages_.begin(), scratch_pages_.end());
        constexpr std::uint32_t kPage = roam::TileMesh::kSlotsPerPage;
        std::size_t k = 0;
        while (k < scratch_pages_.size()) {
            std::size_t end = k + 1;
            while (end < scratch_pages_.size() &&
                   scratch_pages_[end] == scratch_pages_[end - 1] + 1)
                ++end;
            const std::uint32_t first = scratch_pages_[k] * kPage;
            const std::uint32_t last = std::min(slots, (scratch_pages_[end - 1] + 1) * kPage);
            if (first < last) {
                const std::uint64_t run = std::uint64_t{last - first} * kIndexBytesPerSlot;
                gl_.BufferSubData(
                    GL_ELEMENT_ARRAY_BUFFER,
                    static_cast<GLintptr>(std::uint64_t{first} * kIndexBytesPerSlot), sizeOf(run),
                    indices + std::size_t{first} * 3);
                bytes += run;
                ++stats.index_uploads;
            }
            k = end;
        }
    }
    mesh.takeChanges();
    tb.has_indices = true;
    stats.index_bytes += bytes;
    ++stats.index_tiles;
}

DrawStats TerrainRenderer::draw(
    const roam::Tessellator& tess, const roam::Camera& camera, const RenderOptions& options) {
    context_.makeCurrent();
    DrawStats stats;
    const GlApi& gl = gl_;
    gl.Viewport(0, 0, context_.width(), context_.height());
    gl.ClearColor(options.sky.x, options.sky.y, options.sky.z, 1.0f);
    gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    if (tiles_.empty())
        return stats;
    program_->beginFrame(gl, camera, spec_, height_lo_, height_hi_, options);

    if (options.mode == DrawMode::kWireframe) {
        gl.PolygonMode(GL_FRONT_AND_BACK, GL_LINE);
        drawTiles(tess, camera, stats);
    } else {
        gl.PolygonMode(GL_FRONT_AND_BACK, GL_FILL);
        if (options.mode == DrawMode::kShadedWireframe) {
            // push the fill back so the lines drawn over it win the depth test
            gl.Enable(GL_POLYGON_OFFSET_FILL);
            gl.PolygonOffset(1.0f, 1.0f);
        }
        drawTiles(tess, camera, stats);
        if (options.mode == DrawMode::kShadedWireframe) {
            gl.Disable(GL_POLYGON_OFFSET_FILL);
            gl.PolygonMode(GL_FRONT_AND_BACK, GL_LINE);
            program_->setLineColour(gl, 0.05f, 0.05f, 0.08f, 0.6f);
            DrawStats lines;
            drawTiles(tess, camera, lines);
        }
    }
    gl.PolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    gl.BindVertexArray(0);
    program_->endFrame(gl);
    return stats;
}

void TerrainRenderer::drawTiles(
    const roam::Tessellator& tess, const roam::Camera& camera, DrawStats& stats) {
    const double spacing = spec_.spacingMetres();
    const double tile_metres = kTileCells * spacing;
    for (std::int32_t t = 0; t < tess.tileCount(); ++t) {
        const TileBuffers& tb = tiles_[static_cast<std::size_t>(t)];
        if (tb.triangles == 0 || !tess.tileVisible(t))
            continue;
        const double corner_x = (t % spec_.tilesX()) * tile_metres;
        const double corner_y = (t / spec_.tilesX()) * tile_metres;
        program_->setOrigin(gl_, camera, spec_, corner_x, corner_y);
        gl_.BindVertexArray(tb.vao);
        gl_.DrawElements(
            GL_TRIANGLES, static_cast<GLsizei>(tb.triangles * 3), GL_UNSIGNED_INT, nullptr);
        ++stats.tiles;
        stats.triangles += tb.triangles;
    }
}

} // namespace terrain::render
