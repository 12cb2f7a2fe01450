#include <terrain/lodlab/chunked_lod.h>
#include <terrain/lodlab/lod_method.h>
#include <terrain/roam/tessellator.h>
#include <terrain/surface_query.h>

#include <algorithm>
#include <limits>

namespace terrain::lodlab {
namespace {

constexpr std::int64_t kVertexBytes = 16; ///< the renderer's GpuVertex
constexpr std::int64_t kIndexBytes = 12;  ///< per triangle

std::size_t sz(std::int64_t v) {
    return static_cast<std::size_t>(v);
}

// ---------------------------------------------------------------------------------------------
// ROAM, either mode: the product's tessellator; uploads as TerrainRenderer makes them (the
// index bytes the tile meshes wrote, and a tile's whole vertex array when its version moved
// while in view: an upper bound on the renderer's run-diffed vertex uploads)

class RoamMethod final : public LodMethod {
  public:
    /// morph_fraction 0: no geomorphing; else refined to that share of tau and morphed.
    RoamMethod(
        const Terrain& terrain,
        const MethodOptions& options,
        roam::TessellationMode mode,
        double morph_fraction)
        : tess_(terrain, tessellatorOptions(options, mode, morph_fraction)), mode_(mode),
          morph_fraction_(morph_fraction) {
        uploaded_version_.assign(sz(tess_.tileCount()), 0);
        uploaded_.assign(sz(tess_.tileCount()), 0);
        drawn_.resize(sz(tess_.tileCount()));
    }

    Method method() const override {
        if (morph_fraction_ > 0.0)
            return Method::kSplitMergeMorph;
        return mode_ == roam::TessellationMode::kSplitMerge ? Method::kSplitMerge
                                                            : Method::kSplitOnly;
    }

    MethodFrame update(const roam::Camera& camera) override {
        const roam::FrameStats st = tess_.update(camera);
        const roam::ViewMetric view(camera);
        MethodFrame f;
        f.triangles = st.visible_triangles;
        f.upload_bytes = st.index_bytes_written;
        for (std::int32_t t = 0; t < tess_.tileCount(); ++t) {
            tess_.tileMesh(t).takeChanges();
            if (!tess_.tileVisible(t))
                continue;
            const std::uint32_t version = tess_.tileVertexVersion(t);
            const bool whole = uploaded_[sz(t)] == 0 || uploaded_version_[sz(t)] != version;
            if (whole) {
                f.upload_bytes += std::int64_t{tess_.tileVertexCount(t)} * kVertexBytes;
                uploaded_version_[sz(t)] = version;
                uploaded_[sz(t)] = 1;
            }
            if (morph_fraction_ > 0.0) {
                // the renderer sends the vertices whose drawn height moved
                std::vector<double>& drawn = drawn_[sz(t)];
                morph_scratch_.assign(drawn.begin(), drawn.end()); // last frame's
                drawn.resize(sz(tess_.tileVertexCount(t)), 0.0);
                tess_.morphedHeights(t, view, morphFull(), drawn);
                if (!whole)
                    for (std::size_t i = 0; i < drawn.size(); ++i)
                        if (i >= morph_scratch_.size() ||
                            static_cast<float>(drawn[i]) != static_cast<float>(morph_scratch_[i]))
                            f.upload_bytes += kVertexBytes;
            }
        }
        f.error_bound_pixels = morph_fraction_ > 0.0 ? std::max(st.error_bound_pixels, morphFull())
                                                     : st.error_bound_pixels;
        f.rebuilt = st.rebuilt;
        f.over_budget = st.budget_exhausted;
        f.operations = st.splits + st.merges;
        return f;
    }

    void terrainChanged(std::span<const CellRect> cells, bool all) override {
        tess_.terrainChanged(cells, all);
    }

    void visibleTriangles(std::vector<glm::dvec3>& out) const override {
        out.clear();
        const double mpl = tess_.metresPerLattice();
        const double mpf = tess_.metresPerFineUnit();
        for (std::int32_t tile = 0; tile < tess_.tileCount(); ++tile) {
            if (!tess_.tileVisible(tile))
                continue;
            const auto indices = tess_.tileMesh(tile).indices();
            for (std::size_t i = 0; i + 2 < indices.size(); i += 3) {
                if (indices[i] == 0 && indices[i + 1] == 0 && indices[i + 2] == 0)
                    continue; // a free slot
                for (std::size_t j = 0; j < 3; ++j) {
                    const roam::TileVertex v = tess_.tileVertex(tile, indices[i + j]);
                    const double z = morph_fraction_ > 0.0 ? drawn_[sz(tile)][indices[i + j]]
                                                           : static_cast<double>(v.height) * mpf;
                    out.push_back({v.position.x * mpl, v.position.y * mpl, z});
                }
            }
        }
    }

    void allTriangles(std::vector<LatticeTriangle>& out) const override {
        out.clear();
        tess_.forEachLeaf([&](const roam::Triangle& t, std::int32_t, bool) {
            out.push_back({t.apex.x, t.apex.y, t.left.x, t.left.y, t.right.x, t.right.y});
        });
    }

    std::size_t memoryBytes() const override { return tess_.memoryBytes(); }

    roam::Tessellator& tessellator() { return tess_; }

  private:
    /// Where vertices reach their height: tau scaled back from the refinement's threshold (the
    /// cap's, when it binds).
    double morphFull() const { return tess_.threshold() / morph_fraction_; }

    static roam::TessellatorOptions
    tessellatorOptions(const MethodOptions& o, roam::TessellationMode mode, double morph_fraction) {
        roam::TessellatorOptions t;
        t.tau_pixels = morph_fraction > 0.0 ? o.tau_pixels * morph_fraction : o.tau_pixels;
        t.max_triangles = o.max_triangles;
        t.mode = mode;
        return t;
    }

    roam::Tessellator tess_;
    roam::TessellationMode mode_;
    double morph_fraction_ = 0.0;
    std::vector<std::vector<double>> drawn_; ///< per tile: morphed heights (metres) last frame
    std::vector<double> morph_scratch_;
    std::vector<std::uint32_t> uploaded_version_;
    std::vector<std::uint8_t> uploaded_;
};

// ---------------------------------------------------------------------------------------------
// the full-resolution mesh: every base cell's two triangles, every patch cell as 16 x 16
// lattice squares (512 triangles, the lattice's resolution); static buffers per 64-cell tile,
// loaded when first in view and when an op changes the tile; culled by tile

class FullMesh final : public LodMethod {
  public:
    explicit FullMesh(const Terrain& terrain) : terrain_(&terrain) {
        const WorldSpec& spec = terrain.spec();
        tiles_x_ = spec.tilesX();
        tiles_y_ = spec.tilesY();
        tiles_.resize(sz(tiles_x_) * sz(tiles_y_));
        terrainChanged({}, true);
    }

    Method method() const override { return Method::kFullMesh; }

    MethodFrame update(const roam::Camera& camera) override {
        const roam::ViewMetric view(camera);
        MethodFrame f;
        for (Tile& t : tiles_) {
            t.visible = t.triangles > 0 && view.intersectsFrustum(t.box);
            if (!t.visible)
                continue;
            f.triangles += t.triangles;
            if (!t.loaded) {
                f.upload_bytes += t.vertices * kVertexBytes + t.triangles * kIndexBytes;
                t.loaded = true;
            }
            ++f.operations;
        }
        return f;
    }

    void terrainChanged(std::span<const CellRect> cells, bool all) override {
        const WorldSpec& spec = terrain_->spec();
        for (std::int32_t ty = 0; ty < tiles_y_; ++ty)
            for (std::int32_t tx = 0; tx < tiles_x_; ++tx) {
                const CellRect tile{
                    tx * kTileCells, ty * kTileCells,
                    std::min(tx * kTileCells + kTileCells, spec.cellsX()) - 1,
                    std::min(ty * kTileCells + kTileCells, spec.cellsY()) - 1};
                bool touched = all;
                for (const CellRect& c : cells)
                    touched = touched || !(c.x1 < tile.x0 - 1 || c.x0 > tile.x1 + 1 ||
                                           c.y1 < tile.y0 - 1 || c.y0 > tile.y1 + 1);
                if (touched)
                    measureTile(tiles_[sz(ty) * sz(tiles_x_) + sz(tx)], tile);
            }
    }

    void visibleTriangles(std::vector<glm::dvec3>& out) const override {
        out.clear();
        const double s = terrain_->spec().spacingMetres();
        forEachTriangle(true, [&](const LatticeTriangle& t) {
            for (int k = 0; k < 3; ++k) {
                const double x = static_cast<double>(t[sz(2 * k)]) / 16.0 * s;
                const double y = static_cast<double>(t[sz(2 * k + 1)]) / 16.0 * s;
                out.push_back({x, y, surfaceHeight(*terrain_, x, y)});
            }
        });
    }

    void allTriangles(std::vector<LatticeTriangle>& out) const override {
        out.clear();
        forEachTriangle(false, [&](const LatticeTriangle& t) { out.push_back(t); });
    }

    std::size_t memoryBytes() const override { return tiles_.capacity() * sizeof(Tile); }

  private:
    struct Tile {
        CellRect cells;
        roam::Box box;
        std::int64_t triangles = 0;
        std::int64_t vertices = 0;
        bool loaded = false;
        bool visible = false;
    };

    void measureTile(Tile& t, const CellRect& cells) {
        const WorldSpec& spec = terrain_->spec();
        const double s = spec.spacingMetres();
        t.cells = cells;
        t.triangles = 0;
        t.vertices = std::int64_t{cells.x1 - cells.x0 + 2} * (cells.y1 - cells.y0 + 2);
        double lo = std::numeric_limits<double>::infinity();
        double hi = -lo;
        for (std::int32_t y = cells.y0; y <= cells.y1 + 1; ++y)
            for (std::int32_t x = cells.x0; x <= cells.x1 + 1; ++x) {
                const double h = terrain_->sample(x, y) * spec.metresPerUnit();
                lo = std::min(lo, h);
                hi = std::max(hi, h);
            }
        for (std::int32_t y = cells.y0; y <= cells.y1; ++y)
            for (std::int32_t x = cells.x0; x <= cells.x1; ++x) {
                const DetailPatch* p = terrain_->findPatch(x, y);
                if (p == nullptr) {
                    t.triangles += 2;
                    continue;
                }
                t.triangles += 512;
                t.vertices += 17 * 17 - 4;
                const double d = p->deviation_bound * spec.metresPerUnit();
                // a patch stays within deviation_bound of its base triangles, whose heights
                // lie between the corners'
                for (int c = 0; c < 4; ++c) {
                    const double h =
                        terrain_->sample(x + (c & 1), y + (c >> 1)) * spec.metresPerUnit();
                    lo = std::min(lo, h - d);
                    hi = std::max(hi, h + d);
                }
            }
        t.box.lo = {cells.x0 * s, cells.y0 * s, lo};
        t.box.hi = {(cells.x1 + 1) * s, (cells.y1 + 1) * s, hi};
        if (t.loaded)
            t.loaded = false; // reloaded when next in view
    }

    template <class Visit> void forEachTriangle(bool visible_only, Visit&& visit) const {
        for (const Tile& t : tiles_) {
            if (visible_only && !t.visible)
                continue;
            for (std::int32_t y = t.cells.y0; y <= t.cells.y1; ++y)
                for (std::int32_t x = t.cells.x0; x <= t.cells.x1; ++x) {
                    const bool patch = terrain_->findPatch(x, y) != nullptr;
                    const std::int64_t n = patch ? 16 : 1; // squares per side
                    const std::int64_t step = 16 / n;
                    for (std::int64_t j = 0; j < n; ++j)
                        for (std::int64_t i = 0; i < n; ++i) {
                            const std::int64_t x0 = x * 16 + i * step;
                            const std::int64_t y0 = y * 16 + j * step;
                            const std::int64_t x1 = x0 + step;
                            const std::int64_t y1 = y0 + step;
                            // the base cell's diagonal rule, at either scale
                            const bool odd = (((x0 + y0) / step) & 1) != 0;
                            if (!odd) {
                                visit(LatticeTriangle{x0, y0, x1, y0, x1, y1});
                                visit(LatticeTriangle{x0, y0, x1, y1, x0, y1});
                            } else {
                                visit(LatticeTriangle{x0, y0, x1, y0, x0, y1});
                                visit(LatticeTriangle{x1, y0, x1, y1, x0, y1});
                            }
                        }
                }
        }
    }

    const Terrain* terrain_;
    std::int32_t tiles_x_ = 0;
    std::int32_t tiles_y_ = 0;
    std::vector<Tile> tiles_;
};

// ---------------------------------------------------------------------------------------------

class ChunkedMethod final : public LodMethod {
  public:
    ChunkedMethod(const Terrain& terrain, const MethodOptions& options)
        : lod_(terrain, {options.tau_pixels, options.max_triangles, 300}) {}

    Method method() const override { return Method::kChunked; }

    MethodFrame update(const roam::Camera& camera) override {
        const ChunkedFrame c = lod_.update(camera);
        MethodFrame f;
        f.triangles = c.triangles;
        f.upload_bytes = c.upload_bytes;
        f.error_bound_pixels = c.error_bound_pixels;
        f.over_budget = c.capped;
        f.operations = c.nodes_visited + c.forced_splits;
        return f;
    }

    void terrainChanged(std::span<const CellRect> cells, bool all) override {
        lod_.terrainChanged(cells, all);
    }

    void visibleTriangles(std::vector<glm::dvec3>& out) const override {
        lod_.triangles(true, out);
    }

    void allTriangles(std::vector<LatticeTriangle>& out) const override {
        std::vector<std::array<std::int32_t, 6>> grid;
        lod_.gridTriangles(false, grid);
        out.clear();
        for (const auto& t : grid)
            out.push_back(
                {std::int64_t{t[0]} * 16, std::int64_t{t[1]} * 16, std::int64_t{t[2]} * 16,
                 std::int64_t{t[3]} * 16, std::int64_t{t[4]} * 16, std::int64_t{t[5]} * 16});
    }

    std::size_t memoryBytes() const override { return lod_.memoryBytes(); }

  private:
    ChunkedLod lod_;
};

} // namespace

const char* toString(Method method) {
    switch (method) {
    case Method::kSplitMerge:
        return "split_merge";
    case Method::kSplitOnly:
        return "split_only";
    case Method::kFullMesh:
        return "full_mesh";
    case Method::kChunked:
        return "chunked";
    case Method::kSplitMergeMorph:
        return "split_merge_morph";
    }
    return "?";
}

std::optional<Method> parseMethod(const std::string& name) {
    for (Method m : kAllMethods)
        if (name == toString(m))
            return m;
    return std::nullopt;
}

std::unique_ptr<LodMethod>
makeMethod(Method method, const Terrain& terrain, const MethodOptions& options) {
    switch (method) {
    case Method::kSplitMerge:
        return std::make_unique<RoamMethod>(
            terrain, options, roam::TessellationMode::kSplitMerge, 0.0);
    case Method::kSplitOnly:
        return std::make_unique<RoamMethod>(
            terrain, options, roam::TessellationMode::kSplitOnly, 0.0);
    case Method::kSplitMergeMorph:
        return std::make_unique<RoamMethod>(
            terrain, options, roam::TessellationMode::kSplitMerge, kMorphFraction);
    case Method::kFullMesh:
        return std::make_unique<FullMesh>(terrain);
    case Method::kChunked:
        return std::make_unique<ChunkedMethod>(terrain, options);
    }
    return nullptr;
}

} // namespace terrain::lodlab
