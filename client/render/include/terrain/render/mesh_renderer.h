#pragma once

// Draws any triangle soup in world metres with the terrain program (the shading TerrainRenderer
// uses), uploaded whole on every call: the reference renders of the speed-against-accuracy
// benchmark (lod_bench: each method's frame and the full-resolution one), not a production path.
// Vertex normals are the true surface's; colours follow the heights of the world it was created
// for, as TerrainRenderer's do.

#include <terrain/io/png_image.h>
#include <terrain/render/gl_context.h>
#include <terrain/render/terrain_renderer.h>
#include <terrain/roam/camera.h>
#include <terrain/terrain.h>

#include <glm/vec3.hpp>

#include <memory>
#include <span>
#include <vector>

namespace terrain::render {

class TerrainProgram;

class MeshRenderer {
  public:
    /// Compiles the program in `context` (current on this thread).
    static Result<std::unique_ptr<MeshRenderer>>
    create(const GlContext& context, const Terrain& terrain);
    ~MeshRenderer();
    MeshRenderer(const MeshRenderer&) = delete;
    MeshRenderer& operator=(const MeshRenderer&) = delete;

    /// Clears to the sky, draws the triangles (three points each) of `terrain`'s surface as
    /// seen by `camera`, and reads the frame back.
    io::RgbImage render(
        std::span<const glm::dvec3> triangles,
        const Terrain& terrain,
        const roam::Camera& camera,
        const RenderOptions& options = {});

  private:
    explicit MeshRenderer(const GlContext& context);

    const GlContext& context_;
    const GlApi& gl_;
    std::unique_ptr<TerrainProgram> program_;
    unsigned vao_ = 0;
    unsigned buffer_ = 0;
    float height_lo_ = 0.0f;
    float height_hi_ = 0.0f;
    std::vector<float> scratch_;
};

} // namespace terrain::render
