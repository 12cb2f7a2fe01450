#pragma once

// What the renderer uploads and draws from, whichever side made it: the tessellator itself (the
// synchronous path: vertices built from it and the terrain as they are sent) or the frame
// thread's copy of a worker's tiles (roam::DrawnMesh: vertices already built). Per tile: the
// vertex array and index list, what changed in them since the renderer last took the changes,
// and whether the tile is in view. Private to the renderer.

#include <terrain/render/terrain_renderer.h>
#include <terrain/roam/drawn_mesh.h>
#include <terrain/roam/tessellator.h>
#include <terrain/roam/tile_vertex_builder.h>

#include <cstdint>
#include <span>
#include <utility>

namespace terrain::render {

class TileSource {
  public:
    virtual ~TileSource() = default;
    virtual const WorldSpec& spec() const = 0;
    /// Lowest and highest ground (metres) of the world: the colours' scale.
    virtual std::pair<float, float> heightRange() const = 0;
    virtual std::int32_t tileCount() const = 0;
    virtual bool visible(std::int32_t tile) const = 0;

    virtual std::uint32_t vertexCount(std::int32_t tile) const = 0;
    virtual std::uint32_t vertexVersion(std::int32_t tile) const = 0;
    virtual bool verticesAllChanged(std::int32_t tile) const = 0;
    virtual std::span<const roam::VertexRange> vertexChanges(std::int32_t tile) const = 0;
    virtual void takeVertexChanges(std::int32_t tile) = 0;
    /// The vertices [first, first + out.size()) as drawn, normals included.
    virtual void
    vertices(std::int32_t tile, std::uint32_t first, std::span<GpuVertex> out) const = 0;
    /// The same, where the normal may be left 0 (validation's cheap pass).
    virtual void
    positions(std::int32_t tile, std::uint32_t first, std::span<GpuVertex> out) const = 0;

    /// Three indices per slot; every slot is drawn.
    virtual std::span<const std::uint32_t> indices(std::int32_t tile) const = 0;
    virtual std::uint32_t triangleCount(std::int32_t tile) const = 0;
    virtual bool indicesDirty(std::int32_t tile) const = 0;
    virtual bool indicesRewritten(std::int32_t tile) const = 0;
    /// Pages (TileMesh::kSlotsPerPage slots) written since taken, in any order; pages past the
    /// list's end need nothing.
    virtual std::span<const std::uint32_t> dirtyPages(std::int32_t tile) const = 0;
    virtual void takeIndexChanges(std::int32_t tile) = 0;
};

/// The synchronous path: the tessellator's tiles, vertices built from it and `terrain`.
class TessellatorTiles final : public TileSource {
  public:
    TessellatorTiles(
        roam::Tessellator& tess, const Terrain& terrain, roam::TileVertexBuilder& builder)
        : tess_(tess), changes_(&tess), terrain_(terrain), builder_(builder) {}
    /// Reads only (validation after morph()): taking changes is not allowed.
    TessellatorTiles(
        const roam::Tessellator& tess, const Terrain& terrain, roam::TileVertexBuilder& builder)
        : tess_(tess), terrain_(terrain), builder_(builder) {}
    const WorldSpec& spec() const override { return terrain_.spec(); }
    std::pair<float, float> heightRange() const override;
    std::int32_t tileCount() const override { return tess_.tileCount(); }
    bool visible(std::int32_t tile) const override { return tess_.tileVisible(tile); }
    std::uint32_t vertexCount(std::int32_t tile) const override {
        return static_cast<std::uint32_t>(tess_.tileVertexCount(tile));
    }
    std::uint32_t vertexVersion(std::int32_t tile) const override {
        return tess_.tileVertexVersion(tile);
    }
    bool verticesAllChanged(std::int32_t tile) const override {
        return tess_.tileVerticesAllChanged(tile);
    }
    std::span<const roam::VertexRange> vertexChanges(std::int32_t tile) const override {
        return tess_.tileVertexChanges(tile);
    }
    void takeVertexChanges(std::int32_t tile) override { changes_->takeVertexChanges(tile); }
    void vertices(std::int32_t tile, std::uint32_t first, std::span<GpuVertex> out) const override {
        builder_.build(tess_, terrain_, tile, first, out);
    }
    void
    positions(std::int32_t tile, std::uint32_t first, std::span<GpuVertex> out) const override {
        builder_.positions(tess_, tile, first, out);
    }
    std::span<const std::uint32_t> indices(std::int32_t tile) const override {
        return tess_.tileMesh(tile).indices();
    }
    std::uint32_t triangleCount(std::int32_t tile) const override {
        return tess_.tileMesh(tile).triangleCount();
    }
    bool indicesDirty(std::int32_t tile) const override { return tess_.tileMesh(tile).dirty(); }
    bool indicesRewritten(std::int32_t tile) const override {
        return tess_.tileMesh(tile).rewritten();
    }
    std::span<const std::uint32_t> dirtyPages(std::int32_t tile) const override {
        return tess_.tileMesh(tile).dirtyPages();
    }
    void takeIndexChanges(std::int32_t tile) override { changes_->tileMesh(tile).takeChanges(); }

  private:
    const roam::Tessellator& tess_;
    roam::Tessellator* changes_ = nullptr; ///< null when it reads only
    const Terrain& terrain_;
    roam::TileVertexBuilder& builder_;
};

/// The asynchronous path: the frame thread's copy of a worker's tiles.
class DrawnTiles final : public TileSource {
  public:
    explicit DrawnTiles(roam::DrawnMesh& mesh) : mesh_(mesh) {}
    const WorldSpec& spec() const override { return mesh_.spec(); }
    std::pair<float, float> heightRange() const override { return mesh_.heightRange(); }
    std::int32_t tileCount() const override { return mesh_.tileCount(); }
    bool visible(std::int32_t tile) const override { return mesh_.tileVisible(tile); }
    std::uint32_t vertexCount(std::int32_t tile) const override {
        return static_cast<std::uint32_t>(mesh_.vertices(tile).size());
    }
    std::uint32_t vertexVersion(std::int32_t tile) const override {
        return mesh_.vertexVersion(tile);
    }
    bool verticesAllChanged(std::int32_t tile) const override {
        return mesh_.verticesAllChanged(tile);
    }
    std::span<const roam::VertexRange> vertexChanges(std::int32_t tile) const override {
        return mesh_.vertexChanges(tile);
    }
    void takeVertexChanges(std::int32_t tile) override { mesh_.takeVertexChanges(tile); }
    void vertices(std::int32_t tile, std::uint32_t first, std::span<GpuVertex> out) const override;
    void
    positions(std::int32_t tile, std::uint32_t first, std::span<GpuVertex> out) const override {
        vertices(tile, first, out);
    }
    std::span<const std::uint32_t> indices(std::int32_t tile) const override {
        return mesh_.indices(tile);
    }
    std::uint32_t triangleCount(std::int32_t tile) const override {
        return mesh_.slotCount(tile); // dense: the worker's lists are taken at a frame's end
    }
    bool indicesDirty(std::int32_t tile) const override { return mesh_.indicesDirty(tile); }
    bool indicesRewritten(std::int32_t tile) const override { return mesh_.indicesRewritten(tile); }
    std::span<const std::uint32_t> dirtyPages(std::int32_t tile) const override {
        return mesh_.dirtyPages(tile);
    }
    void takeIndexChanges(std::int32_t tile) override { mesh_.takeIndexChanges(tile); }

  private:
    roam::DrawnMesh& mesh_;
};

} // namespace terrain::render
