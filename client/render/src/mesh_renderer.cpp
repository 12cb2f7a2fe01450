#include "shader_program.h"
#include "terrain_shaders.h"

#include <terrain/render/mesh_renderer.h>
#include <terrain/surface_query.h>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain::render {

Result<std::unique_ptr<MeshRenderer>>
MeshRenderer::create(const GlContext& context, const Terrain& terrain) {
    context.makeCurrent();
    std::unique_ptr<MeshRenderer> r(new MeshRenderer(context));
    Result<unsigned> program = buildProgram(r->gl_, kTerrainVertexShader, kTerrainFragmentShader);
    if (!program)
        return program.error();
    r->program_ = *program;
    const GlApi& gl = r->gl_;
    r->u_view_projection_ = gl.GetUniformLocation(r->program_, "u_view_projection");
    r->u_tile_from_eye_ = gl.GetUniformLocation(r->program_, "u_tile_from_eye");
    r->u_clip_ = gl.GetUniformLocation(r->program_, "u_clip");
    r->u_sun_ = gl.GetUniformLocation(r->program_, "u_sun");
    r->u_sky_ = gl.GetUniformLocation(r->program_, "u_sky");
    r->u_haze_ = gl.GetUniformLocation(r->program_, "u_haze");
    r->u_height_range_ = gl.GetUniformLocation(r->program_, "u_height_range");
    r->u_line_colour_ = gl.GetUniformLocation(r->program_, "u_line_colour");
    gl.GenVertexArrays(1, &r->vao_);
    gl.GenBuffers(1, &r->buffer_);
    gl.BindVertexArray(r->vao_);
    gl.BindBuffer(GL_ARRAY_BUFFER, r->buffer_);
    constexpr GLsizei kStride = 6 * sizeof(float);
    gl.EnableVertexAttribArray(0);
    gl.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, kStride, nullptr);
    gl.EnableVertexAttribArray(1);
    gl.VertexAttribPointer(
        1, 3, GL_FLOAT, GL_FALSE, kStride,
        reinterpret_cast<const void*>(3 * sizeof(float))); // GL's offsets are pointers by API
    gl.BindVertexArray(0);
    const WorldSpec& spec = terrain.spec();
    r->height_lo_ = std::numeric_limits<float>::max();
    r->height_hi_ = std::numeric_limits<float>::lowest();
    for (std::int32_t y = 0; y < spec.height; ++y)
        for (std::int32_t x = 0; x < spec.width; ++x) {
            const auto z = static_cast<float>(terrain.sample(x, y) * spec.metresPerUnit());
            r->height_lo_ = std::min(r->height_lo_, z);
            r->height_hi_ = std::max(r->height_hi_, z);
        }
    return r;
}

MeshRenderer::MeshRenderer(const GlContext& context) : context_(context), gl_(context.gl()) {}

MeshRenderer::~MeshRenderer() {
    context_.makeCurrent();
    gl_.DeleteVertexArrays(1, &vao_);
    gl_.DeleteBuffers(1, &buffer_);
    if (program_ != 0)
        gl_.DeleteProgram(program_);
}

io::RgbImage MeshRenderer::render(
    std::span<const glm::dvec3> triangles,
    const Terrain& terrain,
    const roam::Camera& camera,
    const RenderOptions& options) {
    context_.makeCurrent();
    const GlApi& gl = gl_;
    const WorldSpec& spec = terrain.spec();
    // positions relative to a corner near the eye (floats keep millimetres), z absolute
    const double origin_x = std::floor(camera.eye.x / 1024.0) * 1024.0;
    const double origin_y = std::floor(camera.eye.y / 1024.0) * 1024.0;
    scratch_.resize(triangles.size() * 6);
    for (std::size_t i = 0; i < triangles.size(); ++i) {
        const glm::dvec3& p = triangles[i];
        const glm::dvec3 n = surfaceNormal(terrain, p.x, p.y);
        float* v = scratch_.data() + 6 * i;
        v[0] = static_cast<float>(p.x - origin_x);
        v[1] = static_cast<float>(p.y - origin_y);
        v[2] = static_cast<float>(p.z);
        v[3] = static_cast<float>(n.x);
        v[4] = static_cast<float>(n.y);
        v[5] = static_cast<float>(n.z);
    }
    gl.Viewport(0, 0, context_.width(), context_.height());
    gl.ClearColor(options.sky.x, options.sky.y, options.sky.z, 1.0f);
    gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    gl.Enable(GL_DEPTH_TEST);
    gl.DepthFunc(GL_LEQUAL);
    for (GLenum plane = 0; plane < 4; ++plane)
        gl.Enable(GL_CLIP_DISTANCE0 + plane);
    gl.UseProgram(program_);
    // as TerrainRenderer::draw: the eye at the origin, the far plane beyond the farthest corner
    const glm::dvec3 forward = glm::normalize(camera.forward);
    const glm::mat4 view = glm::lookAt(glm::vec3(0.0f), glm::vec3(forward), glm::vec3(camera.up));
    const double diagonal = std::hypot(spec.extentX(), spec.extentY());
    const double off_map =
        std::hypot(camera.eye.x - 0.5 * spec.extentX(), camera.eye.y - 0.5 * spec.extentY());
    const double reach = diagonal + off_map + std::abs(camera.eye.z) +
                         std::max(std::abs(height_lo_), std::abs(height_hi_));
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
    gl.Uniform2f(u_height_range_, height_lo_, height_hi_);
    gl.Uniform4f(u_line_colour_, 0.0f, 0.0f, 0.0f, 0.0f);
    gl.Uniform3f(
        u_tile_from_eye_, static_cast<float>(origin_x - camera.eye.x),
        static_cast<float>(origin_y - camera.eye.y), static_cast<float>(-camera.eye.z));
    gl.Uniform4f(
        u_clip_, static_cast<float>(-origin_x), static_cast<float>(-origin_y),
        static_cast<float>(spec.extentX() - origin_x),
        static_cast<float>(spec.extentY() - origin_y));
    gl.BindVertexArray(vao_);
    gl.BindBuffer(GL_ARRAY_BUFFER, buffer_);
    gl.BufferData(
        GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(scratch_.size() * sizeof(float)), scratch_.data(),
        GL_STREAM_DRAW);
    gl.DrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(triangles.size()));
    gl.BindVertexArray(0);
    for (GLenum plane = 0; plane < 4; ++plane)
        gl.Disable(GL_CLIP_DISTANCE0 + plane);
    gl.UseProgram(0);
    return context_.readPixels();
}

} // namespace terrain::render
