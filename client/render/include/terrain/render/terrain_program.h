#pragma once

// The terrain program (terrain_shaders.h) and what every renderer of it sets, once a frame: the
// eye-at-origin view and a projection whose far plane reaches the farthest map corner, the eye
// in lattice units (positions are lattice units from the map's corner), the map's rectangle that
// clips them, the light, haze and height-range uniforms. Nothing changes per draw, so a vertex
// shared by two draws transforms to the same bits. TerrainRenderer and MeshRenderer draw through
// it, so their pictures differ only in the triangles.

#include <terrain/render/gl_api.h>
#include <terrain/render/terrain_renderer.h>
#include <terrain/roam/camera.h>
#include <terrain/terrain.h>
#include <terrain/world_spec.h>

#include <utility>

namespace terrain::render {

class TerrainProgram {
  public:
    /// Compiles and links the program; the error carries the GL's log.
    static Result<TerrainProgram> build(const GlApi& gl);
    void destroy(const GlApi& gl);

    /// Depth test and clip planes on, the program in use, the frame's uniforms set.
    void beginFrame(
        const GlApi& gl,
        const roam::Camera& camera,
        const WorldSpec& spec,
        float height_lo,
        float height_hi,
        const RenderOptions& options) const;
    /// The clip planes off and no program in use.
    void endFrame(const GlApi& gl) const;
    /// Metres per lattice unit (1/16 cell): what a position's x and y count in.
    static double metresPerLattice(const WorldSpec& spec);
    /// The lowest and highest base sample of `terrain` (metres): the colour ramp's ends. Taken
    /// once per world, so that a crater does not recolour the whole map.
    static std::pair<float, float> heightRange(const Terrain& terrain);

    /// A non-zero alpha replaces the shaded colour (line passes).
    void setLineColour(const GlApi& gl, float r, float g, float b, float a) const;

  private:
    unsigned program_ = 0;
    int u_view_projection_ = -1;
    int u_eye_whole_ = -1;
    int u_eye_rest_ = -1;
    int u_metres_per_lattice_ = -1;
    int u_clip_ = -1;
    int u_sun_ = -1;
    int u_sky_ = -1;
    int u_haze_ = -1;
    int u_height_range_ = -1;
    int u_line_colour_ = -1;
};

} // namespace terrain::render
