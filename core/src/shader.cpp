#include "nephele/shader.hpp"

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>

#include <glm/gtc/type_ptr.hpp>

namespace nephele::detail {
struct EmbeddedShader { const char* name; const char* source; };
extern const EmbeddedShader kEmbeddedShaders[];
extern const std::size_t kEmbeddedShaderCount;
}  // namespace nephele::detail

namespace nephele {
using namespace gl;

std::string shaderFileText(const std::string& name) {
    if (const char* dir = std::getenv("NEPHELE_SHADER_DIR"); dir && *dir) {
        std::ifstream in(std::string(dir) + "/" + name, std::ios::binary);
        if (!in) throw ShaderError("shader file '" + name + "' not found in NEPHELE_SHADER_DIR=" + dir);
        std::ostringstream s;
        s << in.rdbuf();
        return s.str();
    }
    for (std::size_t i = 0; i < nephele::detail::kEmbeddedShaderCount; ++i)
        if (name == nephele::detail::kEmbeddedShaders[i].name) return nephele::detail::kEmbeddedShaders[i].source;
    throw ShaderError("no shader file '" + name + "' in shaders/ (embedded at build time)");
}

namespace {

void appendFile(const std::string& file, std::vector<std::string>& files, std::string& out, int depth) {
    if (depth > 16) throw ShaderError(file + ": #include nested more than 16 deep (a cycle?)");
    const int index = static_cast<int>(files.size());
    files.push_back(file);
    std::istringstream in(shaderFileText(file));
    static const std::regex include(R"(^\s*#\s*include\s+"([^"]+)\"\s*$)");
    std::string line;
    int number = 0;
    out += "#line 1 " + std::to_string(index) + "\n";
    while (std::getline(in, line)) {
        ++number;
        std::smatch m;
        if (std::regex_match(line, m, include)) {
            appendFile(m[1].str(), files, out, depth + 1);
            out += "#line " + std::to_string(number + 1) + " " + std::to_string(index) + "\n";
        } else {
            out += line + "\n";
        }
    }
}

// Mesa and most drivers write "0:12(5): error: ..." where 0 is the source-string index.
std::string mapLog(const std::string& log, const std::vector<std::string>& files) {
    static const std::regex where(R"((\d+):(\d+)\((\d+)\))");
    std::string out;
    auto begin = std::sregex_iterator(log.begin(), log.end(), where);
    std::size_t last = 0;
    for (auto it = begin; it != std::sregex_iterator(); ++it) {
        const auto& m = *it;
        const std::size_t index = std::stoul(m[1].str());
        out += log.substr(last, m.position(0) - last);
        out += (index < files.size() ? files[index] : m[1].str()) + ":" + m[2].str() + "(" + m[3].str() + ")";
        last = m.position(0) + m.length(0);
    }
    return out + log.substr(last);
}

const char* stageName(GLenum stage) {
    switch (stage) {
        case GL_VERTEX_SHADER: return "vertex";
        case GL_FRAGMENT_SHADER: return "fragment";
        case GL_GEOMETRY_SHADER: return "geometry";
        case GL_COMPUTE_SHADER: return "compute";
        case GL_TESS_CONTROL_SHADER: return "tessellation control";
        case GL_TESS_EVALUATION_SHADER: return "tessellation evaluation";
        default: return "unknown";
    }
}

}  // namespace

std::string assembleShaderSource(const std::string& file, const std::string& defines,
                                 std::vector<std::string>& files) {
    std::string out = "#version 450 core\n" + defines;
    if (!defines.empty() && defines.back() != '\n') out += "\n";
    appendFile(file, files, out, 0);
    return out;
}

Program Program::build(std::initializer_list<ShaderStage> stages, const std::string& defines) {
    Program p;
    p.program_ = ProgramObject::create();
    std::vector<ShaderObject> shaders;
    std::string names;
    for (const ShaderStage& s : stages) {
        std::vector<std::string> files;
        const std::string source = assembleShaderSource(s.file, defines, files);
        ShaderObject sh = ShaderObject::create(s.stage);
        const char* text = source.c_str();
        glShaderSource(sh.id(), 1, &text, nullptr);
        glCompileShader(sh.id());
        GLint ok = 0, length = 0;
        glGetShaderiv(sh.id(), GL_COMPILE_STATUS, &ok);
        glGetShaderiv(sh.id(), GL_INFO_LOG_LENGTH, &length);
        if (!ok) {
            std::string log(std::max(length, 1), '\0');
            glGetShaderInfoLog(sh.id(), length, nullptr, log.data());
            log.resize(std::strlen(log.c_str()));
            throw ShaderError(std::string(stageName(s.stage)) + " shader " + s.file +
                              " failed to compile:\n" + mapLog(log, files));
        }
        glAttachShader(p.program_.id(), sh.id());
        names += (names.empty() ? "" : " + ") + s.file;
        shaders.push_back(std::move(sh));
    }
    glLinkProgram(p.program_.id());
    GLint ok = 0, length = 0;
    glGetProgramiv(p.program_.id(), GL_LINK_STATUS, &ok);
    glGetProgramiv(p.program_.id(), GL_INFO_LOG_LENGTH, &length);
    for (const ShaderObject& sh : shaders) glDetachShader(p.program_.id(), sh.id());
    if (!ok) {
        std::string log(std::max(length, 1), '\0');
        glGetProgramInfoLog(p.program_.id(), length, nullptr, log.data());
        log.resize(std::strlen(log.c_str()));
        throw ShaderError("program " + names + " failed to link:\n" + log);
    }
    checkAlways(("building program " + names).c_str());
    return p;
}

GLint Program::location(const char* name) const {
    auto it = locations_.find(name);
    if (it != locations_.end()) return it->second;
    const GLint loc = glGetUniformLocation(program_.id(), name);
    locations_.emplace(name, loc);
    return loc;
}

void Program::set(const char* n, int v) const { glProgramUniform1i(id(), location(n), v); }
void Program::set(const char* n, float v) const { glProgramUniform1f(id(), location(n), v); }
void Program::set(const char* n, const glm::vec2& v) const { glProgramUniform2fv(id(), location(n), 1, glm::value_ptr(v)); }
void Program::set(const char* n, const glm::vec3& v) const { glProgramUniform3fv(id(), location(n), 1, glm::value_ptr(v)); }
void Program::set(const char* n, const glm::vec4& v) const { glProgramUniform4fv(id(), location(n), 1, glm::value_ptr(v)); }
void Program::set(const char* n, const glm::mat3& v) const { glProgramUniformMatrix3fv(id(), location(n), 1, GL_FALSE, glm::value_ptr(v)); }
void Program::set(const char* n, const glm::mat4& v) const { glProgramUniformMatrix4fv(id(), location(n), 1, GL_FALSE, glm::value_ptr(v)); }

}  // namespace nephele
