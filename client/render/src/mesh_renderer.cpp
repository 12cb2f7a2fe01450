#include <terrain/render/mesh_renderer.h>
#include <terrain/render/terrain_program.h>
#include <terrain/surface_query.h>

#include <cmath>
#include <tuple>

namespace terrain::render {

Result<std::unique_ptr<MeshRenderer>>
MeshRenderer::create(const GlContext& context, const Terrain& terrain) {
    context.makeCurrent();
    std::unique_ptr<MeshRenderer> r(new MeshRenderer(context));
    Result<TerrainProgram> program = TerrainProgram::build(r->gl_);
    if (!program)
        return program.error();
    r->program_ = std::make_unique<TerrainProgram>(*program);
    const GlApi& gl = r->gl_;
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
    std::tie(r->height_lo_, r->height_hi_) = TerrainProgram::heightRange(terrain);
    return r;
}

MeshRenderer::MeshRenderer(const GlContext& context) : context_(context), gl_(context.gl()) {}

MeshRenderer::~MeshRenderer() {
    context_.makeCurrent();
    gl_.DeleteVertexArrays(1, &vao_);
    gl_.DeleteBuffers(1, &buffer_);
    if (program_ != nullptr)
        program_->destroy(gl_);
}

io::RgbImage MeshRenderer::render(
    std::span<const glm::dvec3> triangles,
    const Terrain& terrain,
    const roam::Camera& camera,
    const RenderOptions& options) {
    context_.makeCurrent();
    const GlApi& gl = gl_;
    const WorldSpec& spec = terrain.spec();
    // positions in lattice units from the map's corner, as the program takes them; z metres
    const double per_lattice = TerrainProgram::metresPerLattice(spec);
    scratch_.resize(triangles.size() * 6);
    for (std::size_t i = 0; i < triangles.size(); ++i) {
        const glm::dvec3& p = triangles[i];
        const glm::dvec3 n = surfaceNormal(terrain, p.x, p.y);
        float* v = scratch_.data() + 6 * i;
        v[0] = static_cast<float>(p.x / per_lattice);
        v[1] = static_cast<float>(p.y / per_lattice);
        v[2] = static_cast<float>(p.z);
        v[3] = static_cast<float>(n.x);
        v[4] = static_cast<float>(n.y);
        v[5] = static_cast<float>(n.z);
    }
    gl.Viewport(0, 0, context_.width(), context_.height());
    gl.ClearColor(options.sky.x, options.sky.y, options.sky.z, 1.0f);
    gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    program_->beginFrame(gl, camera, spec, height_lo_, height_hi_, options);
    gl.BindVertexArray(vao_);
    gl.BindBuffer(GL_ARRAY_BUFFER, buffer_);
    gl.BufferData(
        GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(scratch_.size() * sizeof(float)), scratch_.data(),
        GL_STREAM_DRAW);
    gl.DrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(triangles.size()));
    gl.BindVertexArray(0);
    program_->endFrame(gl);
    return context_.readPixels();
}

} // namespace terrain::render
