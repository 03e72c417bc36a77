// GLSL programs built from the files in shaders/ (embedded at build time).
//
// A source may `#include "file.glsl"` (one level or more). Each chunk gets a
// `#line N FILEINDEX` directive, and compile errors are reported as
// "sky.frag:12(5): error: ..." with the stage, the file and the driver's whole log.
#pragma once

#include "nephele/api.hpp"
#include "nephele/gl.hpp"

#include <glm/glm.hpp>

#include <initializer_list>
#include <string>
#include <unordered_map>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

class ShaderError : public gl::GlError {
public:
    using gl::GlError::GlError;
};

// The text of a shader file: from $NEPHELE_SHADER_DIR when that is set (to edit shaders
// without rebuilding), else the copy embedded at build time. Throws ShaderError if unknown.
std::string shaderFileText(const std::string& name);

// Full source for one stage: `#version 450 core`, `defines`, then the file with its
// includes resolved. `files` receives the file name of each source-string index used in
// `#line` directives, so logs can be mapped back.
std::string assembleShaderSource(const std::string& file, const std::string& defines, std::vector<std::string>& files);

struct ShaderStage {
    GLenum stage;      // GL_VERTEX_SHADER, GL_FRAGMENT_SHADER, ...
    std::string file;  // a file in shaders/
};

class Program {
public:
    Program() = default;
    // Compiles and links; throws ShaderError naming the stage, file, line and log.
    static Program build(std::initializer_list<ShaderStage> stages, const std::string& defines = "");

    GLuint id() const { return program_.id(); }
    explicit operator bool() const { return bool(program_); }
    GLint location(const char* name) const;  // -1 if the uniform is inactive
    // glShaderStorageBlockBinding of the block named `block`, if the program has it: the binding
    // point said once, in C++, where the buffer is bound (the shader's layout gives none).
    void bindStorageBlock(const char* block, GLuint binding) const;

    // glProgramUniform*: no need to bind the program, no host state touched.
    void set(const char* name, int v) const;
    void set(const char* name, float v) const;
    void set(const char* name, const glm::vec2& v) const;
    void set(const char* name, const glm::vec3& v) const;
    void set(const char* name, const glm::vec4& v) const;
    void set(const char* name, const glm::mat3& v) const;
    void set(const char* name, const glm::mat4& v) const;

private:
    gl::ProgramObject program_;
    mutable std::unordered_map<std::string, GLint> locations_;
};

}  // namespace nephele
NEPHELE_API_END
