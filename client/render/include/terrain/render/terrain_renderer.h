#pragma once

// Draws the tessellator's output. Per tile: a vertex buffer (the tile's vertex array: base grid
// + detail blocks, positions and normals) of which only the vertices that changed are sent, and
// an index buffer into which only the dirty pages of the tile's index list are sent. Every byte
// goes through an UploadRing (upload_ring.h): staged during sync(), written once into a
// streaming buffer, and copied by the GPU into the tile buffers, which nothing else writes. A
// buffer a tile outgrows is copied into its successor on the GPU. Only tiles in view or seen
// lately hold buffers (setEvictAfterFrames). Every byte sent to the GL is counted. The renderer
// never decides level of detail: it draws what roam::Tessellator chose, and clips triangles that
// reach into the map's padding.
//
// Watertight: positions are lattice units (1/16 cell) from the map's corner, whole numbers that
// a float holds exactly, and are moved to the eye by uniforms that are the same for every draw of
// a frame; so every copy of a shared vertex (in two tiles, in two cell blocks) reaches the
// rasterizer as the same bits, and a rasterizer's watertightness rules leave no pixel out. (Per
// tile origins moved by a per-draw uniform rounded differently on either side of a tile edge.)
// The eye's position is split into a whole and a fractional part, so floats keep millimetres on
// maps tens of kilometres wide.

#include <terrain/render/gl_context.h>
#include <terrain/render/upload_ring.h>
#include <terrain/roam/camera.h>
#include <terrain/roam/drawn_mesh.h>
#include <terrain/roam/tessellator.h>
#include <terrain/roam/tile_vertex_builder.h>
#include <terrain/terrain.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace terrain::render {

class TerrainProgram;
class TileSource;
struct UploadRun;

/// One vertex in a tile's buffer (roam::DrawVertex: lattice x and y, z in metres, packed normal).
using GpuVertex = roam::DrawVertex;

enum class DrawMode { kShaded, kWireframe, kShadedWireframe };

struct RenderOptions {
    DrawMode mode = DrawMode::kShaded;
    /// Towards the sun (need not be unit length). Low and from the side, so crater walls show.
    glm::vec3 sun{-0.55f, -0.35f, 0.55f};
    glm::vec3 sky{0.62f, 0.74f, 0.88f};
    /// Distance (metres) at which haze has covered 63 % of the colour; 0 disables haze.
    float haze_metres = 0.0f;
};

/// What one sync() sent to the GL.
struct UploadStats {
    std::uint64_t vertex_bytes = 0;
    std::uint64_t index_bytes = 0;
    std::uint32_t vertex_tiles = 0;   ///< tiles whose vertex buffer was written
    std::uint32_t index_tiles = 0;    ///< tiles whose index buffer was written
    std::uint32_t index_uploads = 0;  ///< runs of index pages sent (one GPU copy each)
    std::uint32_t vertex_uploads = 0; ///< runs of vertices sent (one GPU copy each)
    std::uint32_t evicted_tiles = 0;  ///< tiles whose buffers were given back (out of view)
    std::uint32_t loaded_tiles = 0;   ///< tiles whose buffers were (re)created and sent whole
    std::uint64_t load_bytes = 0;     ///< of the bytes, those of tiles loaded whole
    std::uint32_t grown_buffers = 0;  ///< buffers outgrown, their contents moved on the GPU
    std::uint64_t moved_bytes = 0;    ///< bytes those GPU copies moved (not uploaded)
    std::uint64_t bytes() const { return vertex_bytes + index_bytes; }
};

/// How the renderer sends data and whether it checks it.
struct RendererOptions {
    UploadPath upload = UploadPath::kAuto;
    /// Initial size of the streaming ring (it grows when a frame needs more).
    std::uint64_t ring_bytes = 8u << 20;
    /// After every sync() and morph(), read every resident tile's buffers back
    /// (glGetBufferSubData) and compare them with a fresh build from the tessellator; new
    /// buffers are filled with a poison pattern first, so that drawing from a byte never
    /// written shows. For tests and --validate-buffers; slow.
    bool validate = false;
};

/// What validation found (RendererOptions::validate), since creation.
struct ValidationReport {
    std::uint64_t syncs = 0;
    std::uint64_t tiles = 0;             ///< resident tiles compared, all told
    std::uint64_t vertices = 0;          ///< vertices compared
    std::uint64_t indices = 0;           ///< index list entries compared
    std::uint64_t vertex_mismatches = 0; ///< vertices whose 16 bytes differ from a fresh build
    std::uint64_t index_mismatches = 0;  ///< indices that differ from the tile's list
    std::uint64_t short_buffers = 0;     ///< buffers smaller than what they must hold
    /// What the uploads changed in the buffers of tiles already loaded (their contents
    /// compared with the last read back): vertices whose 16 bytes differ, and index pages
    /// (TileMesh::kSlotsPerPage slots) with any slot that differs, in bytes. What uploads
    /// should be proportional to (UploadStats' bytes less load_bytes).
    std::uint64_t changed_vertex_bytes = 0;
    std::uint64_t changed_index_bytes = 0;
    std::string first_problem; ///< where the first mismatch was, for a person
    bool clean() const {
        return vertex_mismatches == 0 && index_mismatches == 0 && short_buffers == 0;
    }
};

struct DrawStats {
    std::uint32_t tiles = 0;
    std::uint64_t triangles = 0;
};

class TerrainRenderer {
  public:
    /// Compiles the shaders in `context` (current on this thread). Errors: kUnsupported with the
    /// compiler's log.
    static Result<std::unique_ptr<TerrainRenderer>>
    create(const GlContext& context, const RendererOptions& options = {});
    ~TerrainRenderer();
    TerrainRenderer(const TerrainRenderer&) = delete;
    TerrainRenderer& operator=(const TerrainRenderer&) = delete;

    /// Brings the GPU buffers up to date with `tess` and takes its changes (the vertex ranges
    /// and index pages it marked: so one tessellator feeds one renderer; a renderer created
    /// later loads everything once), the work proportional to what changed. `terrain` is the
    /// surface `tess` was built on (normals come from it). Usually after tess.update(); a mesh
    /// that terrainChanged() touched since is drawn as it stands (its freed slots are
    /// degenerate triangles, all slots are drawn).
    UploadStats sync(roam::Tessellator& tess, const Terrain& terrain);
    /// The same from the frame thread's copy of a tessellation worker's tiles (the worker built
    /// the vertices: nothing here reads the terrain), taking the copy's changes. A renderer
    /// follows one source: a tessellator or a copy. morph() does not apply to a copy.
    UploadStats sync(roam::DrawnMesh& mesh);
    /// Geomorphing: with `fraction` in (0, 1), morph() draws each vertex sliding between its
    /// hypotenuse's midpoint and its height (roam::Tessellator::morphedHeights), reaching it at
    /// the tessellator's threshold / fraction; the tessellator must then refine to fraction x
    /// the tau wanted (its setTau), and what is drawn is within that tau at every instant. 0:
    /// off (every vertex drawn at its height).
    void setGeomorph(double fraction) { geomorph_ = fraction; }
    double geomorph() const { return geomorph_; }
    /// After sync(), before draw(), with geomorphing on: sends the visible tiles' vertices
    /// whose drawn height moved for `camera` (runs of them, as sync() does). Off: sends the
    /// true heights back to tiles it moved while on, then nothing.
    UploadStats morph(const roam::Tessellator& tess, const roam::Camera& camera);
    /// Clears to the sky and draws the visible tiles as seen by `camera` into the whole
    /// framebuffer.
    DrawStats
    draw(const roam::Tessellator& tess, const roam::Camera& camera, const RenderOptions& options);
    DrawStats
    draw(const roam::DrawnMesh& mesh, const roam::Camera& camera, const RenderOptions& options);

    /// Totals since creation.
    const UploadStats& totals() const { return totals_; }
    /// The streaming ring: the path taken (persistent or map-range) and what it did.
    UploadPath uploadPath() const { return ring_->path(); }
    const RingStats& ringStats() const { return ring_->stats(); }
    /// RendererOptions::validate's findings (all zero when it is off).
    const ValidationReport& validation() const { return validation_; }
    /// Bytes held in GL buffers now.
    std::uint64_t gpuBytes() const;
    /// Bytes of the CPU copies of vertex buffers (what uploads diff against).
    std::uint64_t shadowBytes() const;
    /// Tiles whose buffers are loaded: those in view, and those seen within the last
    /// evictAfterFrames() syncs.
    std::uint32_t residentTiles() const;
    /// A tile out of view for more than this many syncs gives its buffers and CPU copy back
    /// (0: as soon as it leaves the view); it loads in full when seen again.
    void setEvictAfterFrames(std::uint32_t frames) { evict_after_frames_ = frames; }
    std::uint32_t evictAfterFrames() const { return evict_after_frames_; }
    /// 300 syncs: 5 s at 60 frames a second, so a look over the shoulder costs no reload.
    static constexpr std::uint32_t kDefaultEvictAfterFrames = 300;

  private:
    struct TileBuffers {
        unsigned vao = 0; ///< 0 while the tile holds no buffers
        unsigned vertex_buffer = 0;
        unsigned index_buffer = 0;
        std::uint32_t vertex_version = 0;
        bool has_vertices = false;
        std::uint32_t vertex_capacity = 0;
        /// The buffer's contents (true heights): what to send is what differs from it.
        std::vector<GpuVertex> shadow;
        /// The heights in the buffer, which geomorphing moves away from the shadow's.
        std::vector<float> drawn_z;
        bool morphed = false; ///< morph() wrote drawn heights (restored when turned off)
        std::uint32_t index_capacity_slots = 0;
        bool has_indices = false;
        std::uint32_t slots = 0;        ///< index list slots in the buffer (all drawn)
        std::uint64_t last_visible = 0; ///< the sync (frame_) it was last in view
        bool seen = false;
        /// Validation: the buffers as last read back (empty: loaded since).
        std::vector<unsigned char> checked_vertices;
        std::vector<unsigned char> checked_indices;
    };

    TerrainRenderer(const GlContext& context, const RendererOptions& options);
    void releaseTiles();
    void release(TileBuffers& tb);
    void evict(TileBuffers& tb, UploadStats& stats);
    /// A new buffer of `bytes` (poisoned when validating), bound to nothing.
    unsigned createBuffer(std::uint64_t bytes);
    void attachVertexBuffer(const TileBuffers& tb);
    UploadStats syncTiles(TileSource& source);
    void uploadVertices(TileSource& source, std::int32_t tile, TileBuffers& tb, UploadStats& stats);
    void uploadIndices(TileSource& source, std::int32_t tile, TileBuffers& tb, UploadStats& stats);
    /// Appends to scratch_runs_ the runs of vertices first + k for which `differs(k)` holds,
    /// bridging gaps of up to kVertexRunGap.
    template <class Differs>
    void collectRuns(std::uint32_t first, std::uint32_t count, Differs&& differs);
    /// Joins scratch_runs_ (upload_runs.h) and stages them into the tile's vertex buffer from
    /// its shadow, with the drawn heights; returns the bytes.
    std::uint64_t stageVertexRuns(const TileBuffers& tb, UploadStats& stats);
    void validate(const TileSource& source);
    /// Clears and draws the tiles for which visible(t) holds (triangles(t) counted).
    template <class Visible, class Triangles>
    DrawStats drawFrame(
        std::int32_t tiles,
        Visible&& visible,
        Triangles&& triangles,
        const roam::Camera& camera,
        const RenderOptions& options);
    template <class Visible, class Triangles>
    void drawTiles(std::int32_t tiles, Visible& visible, Triangles& triangles, DrawStats& stats);

    const GlContext& context_;
    const GlApi& gl_;
    RendererOptions options_;
    std::unique_ptr<TerrainProgram> program_;
    std::unique_ptr<UploadRing> ring_;

    std::vector<TileBuffers> tiles_;
    WorldSpec spec_{};
    bool have_spec_ = false;
    const Terrain* synced_terrain_ = nullptr; ///< the last sync(tess)'s (validation after morph())
    float height_lo_ = 0.0f;
    float height_hi_ = 0.0f;
    std::uint64_t frame_ = 0; ///< syncs since creation
    std::uint32_t evict_after_frames_ = kDefaultEvictAfterFrames;
    std::vector<roam::VertexRange> scratch_ranges_;
    std::vector<UploadRun> scratch_runs_;
    std::unique_ptr<roam::TileVertexBuilder> builder_;
    std::vector<GpuVertex> scratch_vertices_;
    std::vector<GpuVertex> scratch_staged_;
    std::vector<std::uint32_t> scratch_pages_;
    std::vector<double> scratch_heights_;
    std::vector<std::uint8_t> scratch_send_;
    std::vector<unsigned char> poison_;
    std::vector<GpuVertex> expected_vertices_; ///< validation
    std::vector<unsigned char> readback_;      ///< validation
    std::vector<std::uint8_t> referenced_;     ///< validation: vertices an index refers to
    std::int32_t validated_normals_ = -1;      ///< validation: the tile whose normals were last
    double geomorph_ = 0.0;
    UploadStats totals_;
    ValidationReport validation_;
};

} // namespace terrain::render
