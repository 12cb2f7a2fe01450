#include "shader_program.h"
#include "terrain_shaders.h"

#include <terrain/render/terrain_program.h>
#include <terrain/roam/delta_collector.h>
#include <terrain/roam/drawn_mesh.h>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>

#include <algorithm>
#include <cmath>

namespace terrain::render {

Result<TerrainProgram> TerrainProgram::build(const GlApi& gl) {
    Result<unsigned> program = buildProgram(gl, kTerrainVertexShader, kTerrainFragmentShader);
    if (!program)
        return program.error();
    TerrainProgram p;
    p.program_ = *program;
    p.u_view_projection_ = gl.GetUniformLocation(p.program_, "u_view_projection");
    p.u_eye_whole_ = gl.GetUniformLocation(p.program_, "u_eye_whole");
    p.u_eye_rest_ = gl.GetUniformLocation(p.program_, "u_eye_rest");
    p.u_metres_per_lattice_ = gl.GetUniformLocation(p.program_, "u_metres_per_lattice");
    p.u_clip_ = gl.GetUniformLocation(p.program_, "u_clip");
    p.u_sun_ = gl.GetUniformLocation(p.program_, "u_sun");
    p.u_sky_ = gl.GetUniformLocation(p.program_, "u_sky");
    p.u_haze_ = gl.GetUniformLocation(p.program_, "u_haze");
    p.u_height_range_ = gl.GetUniformLocation(p.program_, "u_height_range");
    p.u_line_colour_ = gl.GetUniformLocation(p.program_, "u_line_colour");
    return p;
}

void TerrainProgram::destroy(const GlApi& gl) {
    if (program_ != 0)
        gl.DeleteProgram(program_);
    program_ = 0;
}

void TerrainProgram::beginFrame(
    const GlApi& gl,
    const roam::Camera& camera,
    const WorldSpec& spec,
    float height_lo,
    float height_hi,
    const RenderOptions& options) const {
    gl.Enable(GL_DEPTH_TEST);
    gl.DepthFunc(GL_LEQUAL);
    for (GLenum plane = 0; plane < 4; ++plane)
        gl.Enable(GL_CLIP_DISTANCE0 + plane);
    gl.UseProgram(program_);

    // eye at the origin: the view matrix is a rotation, positions arrive eye-relative
    const glm::dvec3 forward = glm::normalize(camera.forward);
    const glm::mat4 view = glm::lookAt(glm::vec3(0.0f), glm::vec3(forward), glm::vec3(camera.up));
    const double diagonal = std::hypot(spec.extentX(), spec.extentY());
    // the farthest map corner from the eye, wherever the eye is
    const double off_map =
        std::hypot(camera.eye.x - 0.5 * spec.extentX(), camera.eye.y - 0.5 * spec.extentY());
    const double reach = diagonal + off_map + std::abs(camera.eye.z) +
                         std::max(std::abs(height_lo), std::abs(height_hi));
    const float aspect = static_cast<float>(camera.viewport_width) /
                         static_cast<float>(std::max(camera.viewport_height, 1));
    const glm::mat4 projection = glm::perspective(
        static_cast<float>(camera.fovy_radians), aspect, static_cast<float>(camera.near_plane),
        static_cast<float>(reach * 1.5 + 1.0));
    const glm::mat4 view_projection = projection * view;
    gl.UniformMatrix4fv(u_view_projection_, 1, GL_FALSE, glm::value_ptr(view_projection));
    const glm::vec3 sun = glm::normalize(options.sun);
    gl.Uniform3f(u_sun_, sun.x, sun.y, sun.z);
    gl.Uniform3f(u_sky_, options.sky.x, options.sky.y, options.sky.z);
    gl.Uniform1f(u_haze_, options.haze_metres > 0.0f ? 1.0f / options.haze_metres : 0.0f);
    gl.Uniform2f(u_height_range_, height_lo, height_hi);
    gl.Uniform4f(u_line_colour_, 0.0f, 0.0f, 0.0f, 0.0f);

    // the eye in lattice units, split so that positions minus its whole part are exact
    const double per_lattice = metresPerLattice(spec);
    const double ex = camera.eye.x / per_lattice;
    const double ey = camera.eye.y / per_lattice;
    const double wx = std::floor(ex);
    const double wy = std::floor(ey);
    gl.Uniform2f(u_eye_whole_, static_cast<float>(wx), static_cast<float>(wy));
    gl.Uniform3f(
        u_eye_rest_, static_cast<float>(ex - wx), static_cast<float>(ey - wy),
        static_cast<float>(camera.eye.z));
    gl.Uniform1f(u_metres_per_lattice_, static_cast<float>(per_lattice));
    gl.Uniform2f(
        u_clip_, static_cast<float>(spec.cellsX() * roam::kLatticePerCell),
        static_cast<float>(spec.cellsY() * roam::kLatticePerCell));
}

double TerrainProgram::metresPerLattice(const WorldSpec& spec) {
    return roam::DrawnMesh::metresPerLattice(spec);
}

void TerrainProgram::endFrame(const GlApi& gl) const {
    for (GLenum plane = 0; plane < 4; ++plane)
        gl.Disable(GL_CLIP_DISTANCE0 + plane);
    gl.UseProgram(0);
}

std::pair<float, float> TerrainProgram::heightRange(const Terrain& terrain) {
    return roam::DeltaCollector::heightRange(terrain); // the same scale as a worker's tiles
}

void TerrainProgram::setLineColour(const GlApi& gl, float r, float g, float b, float a) const {
    gl.Uniform4f(u_line_colour_, r, g, b, a);
}

} // namespace terrain::render
