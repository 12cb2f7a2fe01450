#include "shader_program.h"

#include <string>

namespace terrain::render {

namespace {
/// The info log of a shader or program (GetShaderInfoLog or GetProgramInfoLog).
template <typename GetLog> std::string infoLog(GLuint object, GetLog get_log) {
    std::string log(4096, '\0');
    GLsizei length = 0;
    get_log(object, static_cast<GLsizei>(log.size()), &length, log.data());
    log.resize(static_cast<std::size_t>(length));
    return log;
}

Result<GLuint> compile(const GlApi& gl, GLenum kind, const char* source, const char* what) {
    const GLuint shader = gl.CreateShader(kind);
    gl.ShaderSource(shader, 1, &source, nullptr);
    gl.CompileShader(shader);
    GLint ok = 0;
    gl.GetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (ok == GL_TRUE)
        return shader;
    const std::string log = infoLog(shader, gl.GetShaderInfoLog);
    gl.DeleteShader(shader);
    return makeError(ErrorCode::kUnsupported, std::string(what) + " shader: " + log);
}
} // namespace

Result<unsigned>
buildProgram(const GlApi& gl, const char* vertex_source, const char* fragment_source) {
    Result<GLuint> vs = compile(gl, GL_VERTEX_SHADER, vertex_source, "vertex");
    if (!vs)
        return vs.error();
    Result<GLuint> fs = compile(gl, GL_FRAGMENT_SHADER, fragment_source, "fragment");
    if (!fs) {
        gl.DeleteShader(*vs);
        return fs.error();
    }
    const GLuint program = gl.CreateProgram();
    gl.AttachShader(program, *vs);
    gl.AttachShader(program, *fs);
    gl.LinkProgram(program);
    gl.DeleteShader(*vs);
    gl.DeleteShader(*fs);
    GLint ok = 0;
    gl.GetProgramiv(program, GL_LINK_STATUS, &ok);
    if (ok == GL_TRUE)
        return program;
    const std::string log = infoLog(program, gl.GetProgramInfoLog);
    gl.DeleteProgram(program);
    return makeError(ErrorCode::kUnsupported, "shader link: " + log);
}

} // namespace terrain::render
