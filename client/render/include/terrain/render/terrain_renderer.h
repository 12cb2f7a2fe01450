#pragma once

// Draws the tessellator's output. Per tile: a static vertex buffer (the tile's vertex array:
// base grid + detail blocks, positions and normals), rebuilt only when the tile's vertex
// version changes, and an index buffer into which only the dirty pages of the tile's index list
// are copied (glBufferSubData per run of pages; the whole list after a rewrite or growth).
// Only tiles in view or seen lately hold buffers (setEvictAfterFrames).
// Every byte sent to the GL is counted. The renderer never decides level of detail: it draws
// what roam::Tessellator chose, and clips triangles that reach into the map's padding.
//
// Positions are stored relative to each tile's corner and drawn relative to the eye, so floats
// keep millimetres on maps tens of kilometres wide.

#include <terrain/render/gl_context.h>
#include <terrain/roam/camera.h>
#include <terrain/roam/tessellator.h>
#include <terrain/terrain.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace terrain::render {

class TerrainProgram;

/// One vertex in a tile's buffer: metres from the tile's corner (z absolute) and the normal
/// packed as signed 10:10:10:2 (GL_INT_2_10_10_10_REV, normalised).
struct GpuVertex {
    float x = 0.0f;
    float y = 0.0f;
    float z = 0.0f;
    std::uint32_t normal = 0;
};

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
    std::uint32_t vertex_tiles = 0;  ///< tiles whose vertex buffer was rebuilt
    std::uint32_t index_tiles = 0;   ///< tiles whose index buffer was written
    std::uint32_t index_uploads = 0; ///< glBufferData/glBufferSubData calls for indices
    std::uint32_t evicted_tiles = 0; ///< tiles whose buffers were given back (out of view)
    std::uint64_t bytes() const { return vertex_bytes + index_bytes; }
};

struct DrawStats {
    std::uint32_t tiles = 0;
    std::uint64_t triangles = 0;
};

class TerrainRenderer {
  public:
    /// Compiles the shaders in `context` (current on this thread). Errors: kUnsupported with the
    /// compiler's log.
    static Result<std::unique_ptr<TerrainRenderer>> create(const GlContext& context);
    ~TerrainRenderer();
    TerrainRenderer(const TerrainRenderer&) = delete;
    TerrainRenderer& operator=(const TerrainRenderer&) = delete;

    /// Brings the GPU buffers up to date with `tess` (after its update()) and takes its changes
    /// (so one tessellator feeds one renderer; a renderer created later loads everything once).
    /// `terrain` is the surface `tess` was built on (normals come from it).
    UploadStats sync(roam::Tessellator& tess, const Terrain& terrain);
    /// Where the surface changed (the replica's dirty cells; `all` for a snapshot), before the
    /// next sync(). Required for exact normals: vertices within a cell of a change get new ones,
    /// in every tile (a tile's edge vertex samples its neighbour's cells), even where no vertex
    /// moved (a change below a height's rounding, or a float's). Without it only vertices
    /// that moved, and their tile's vertices within a cell of them, are redone.
    void surfaceChanged(std::span<const CellRect> cells, bool all);
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

    /// Totals since creation.
    const UploadStats& totals() const { return totals_; }
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
        unsigned vao = 0;
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
        std::uint32_t triangles = 0;
        std::uint64_t last_visible = 0; ///< the sync (frame_) it was last in view
        bool seen = false;
    };

    struct Region {
        roam::LatticePoint lo;
        roam::LatticePoint hi;
    };

    explicit TerrainRenderer(const GlContext& context);
    bool surfaceChangedIn(std::int32_t tile) const;
    void releaseTiles();
    void evict(TileBuffers& tb, UploadStats& stats);
    void attachVertexBuffer(const TileBuffers& tb);
    void growVertexBuffer(TileBuffers& tb, std::uint32_t count);
    void uploadVertices(
        roam::Tessellator& tess,
        const Terrain& terrain,
        std::int32_t tile,
        TileBuffers& tb,
        UploadStats& stats);
    void uploadIndices(roam::TileMesh& mesh, TileBuffers& tb, UploadStats& stats);
    /// Sends the vertices [0, count) of scratch_vertices_ for which `differs` holds, in runs
    /// that bridge short equal gaps; returns the bytes sent. The buffer is bound.
    template <class Differs> std::uint64_t sendRuns(std::uint32_t count, Differs&& differs);
    void drawTiles(const roam::Tessellator& tess, const roam::Camera& camera, DrawStats& stats);

    const GlContext& context_;
    const GlApi& gl_;
    std::unique_ptr<TerrainProgram> program_;

    std::vector<TileBuffers> tiles_;
    WorldSpec spec_{};
    bool have_spec_ = false;
    float height_lo_ = 0.0f;
    float height_hi_ = 0.0f;
    std::uint64_t frame_ = 0; ///< syncs since creation
    std::uint32_t evict_after_frames_ = kDefaultEvictAfterFrames;
    std::vector<Region> changed_; ///< surfaceChanged() since the last sync, in lattice units
    bool all_changed_ = false;
    std::vector<roam::TileVertex> scratch_keys_;
    std::vector<GpuVertex> scratch_vertices_;
    std::vector<std::uint32_t> scratch_pages_;
    std::vector<double> scratch_heights_;
    std::vector<std::uint8_t> scratch_send_;
    double geomorph_ = 0.0;
    UploadStats totals_;
};

} // namespace terrain::render
