#include "nephele/shader.hpp"

#include "nephele/limits.hpp"

#include "input_file.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string_view>

#include <glm/gtc/type_ptr.hpp>

namespace nephele::detail {
struct EmbeddedShader {
    const char* name;
    const char* source;
};
extern const EmbeddedShader kEmbeddedShaders[];
extern const std::size_t kEmbeddedShaderCount;
}  // namespace nephele::detail

namespace nephele {
using namespace gl;

std::string shaderFileText(const std::string& name) {
    if (const char* dir = std::getenv("NEPHELE_SHADER_DIR"); dir && *dir) {
        const std::string path = std::string(dir) + "/" + name;
        std::string text;
        if (auto fault = nephele::detail::readRegularFile(path, limits::kShaderFileBytes, &text))
            throw ShaderError("shader file '" + name + "' in NEPHELE_SHADER_DIR=" + dir + ": " + *fault);
        if (auto fault = nephele::detail::nulByteFault(text)) throw ShaderError(path + ": " + *fault);
        return text;
    }
    for (std::size_t i = 0; i < nephele::detail::kEmbeddedShaderCount; ++i)
        if (name == nephele::detail::kEmbeddedShaders[i].name) return nephele::detail::kEmbeddedShaders[i].source;
    throw ShaderError("no shader file '" + name + "' in shaders/ (embedded at build time)");
}

namespace {

bool isSpace(char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; }
bool isDigit(char c) { return c >= '0' && c <= '9'; }

// The file a line `#include "name"` names (blanks allowed around '#' and around the name), or
// nothing. A plain scan: std::regex recursed once per character and overflowed the stack on a
// 50 KB line of spaces.
std::optional<std::string_view> includedFile(std::string_view line) {
    auto skip = [&](std::size_t i) {
        while (i < line.size() && isSpace(line[i])) ++i;
        return i;
    };
    std::size_t i = skip(0);
    if (i == line.size() || line[i] != '#') return std::nullopt;
    i = skip(i + 1);
    if (line.substr(i, 7) != "include") return std::nullopt;
    const std::size_t quote = skip(i + 7);
    if (quote == i + 7 || quote == line.size() || line[quote] != '"') return std::nullopt;
    const std::size_t close = line.find('"', quote + 1);
    if (close == std::string_view::npos || close == quote + 1 || skip(close + 1) != line.size()) return std::nullopt;
    return line.substr(quote + 1, close - quote - 1);
}

// The length of a "N:L(C)" source location at the start of s (digits, ':', digits, '(', digits,
// ')'), or 0.
std::size_t locationLength(std::string_view s) {
    std::size_t i = 0;
    for (const char sep : {':', '(', ')'}) {
        const std::size_t start = i;
        while (i < s.size() && isDigit(s[i])) ++i;
        if (i == start || i == s.size() || s[i] != sep) return 0;
        ++i;
    }
    return i;
}

void appendFile(const std::string& file, std::vector<std::string>& files, std::string& out, int depth) {
    if (depth > 16) throw ShaderError(file + ": #include nested more than 16 deep (a cycle?)");
    const int index = static_cast<int>(files.size());
    files.push_back(file);
    const std::string text = shaderFileText(file);
    int number = 0;
    out += "#line 1 " + std::to_string(index) + "\n";
    for (std::size_t start = 0; start < text.size();) {
        const std::size_t end = std::min(text.find('\n', start), text.size());
        const std::string_view line(text.data() + start, end - start);
        start = end + 1;
        ++number;
        if (const auto included = includedFile(line)) {
            appendFile(std::string(*included), files, out, depth + 1);
            out += "#line " + std::to_string(number + 1) + " " + std::to_string(index) + "\n";
        } else {
            out.append(line);
            out += '\n';
        }
    }
}

// Mesa and most drivers write "0:12(5): error: ..." where 0 is the source-string index: the
// index becomes the file's name.
std::string mapLog(const std::string& log, const std::vector<std::string>& files) {
    std::string out;
    for (std::size_t i = 0; i < log.size();) {
        const std::size_t n = (i == 0 || !isDigit(log[i - 1])) ? locationLength(std::string_view(log).substr(i)) : 0;
        if (n == 0) {
            out += log[i++];
            continue;
        }
        const std::size_t colon = log.find(':', i);
        std::size_t index = 0;
        const auto r = std::from_chars(log.data() + i, log.data() + colon, index);
        const bool known = r.ec == std::errc() && index < files.size();
        out += (known ? files[index] : log.substr(i, colon - i)) + log.substr(colon, i + n - colon);
        i += n;
    }
    return out;
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

std::string assembleShaderSource(const std::string& file, const std::string& defines, std::vector<std::string>& files) {
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
            throw ShaderError(std::string(stageName(s.stage)) + " shader " + s.file + " failed to compile:\n" +
                              mapLog(log, files));
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

void Program::bindStorageBlock(const char* block, GLuint binding) const {
    const GLuint index = glGetProgramResourceIndex(id(), GL_SHADER_STORAGE_BLOCK, block);
    if (index != GL_INVALID_INDEX) glShaderStorageBlockBinding(id(), index, binding);
}

void Program::set(const char* n, int v) const { glProgramUniform1i(id(), location(n), v); }
void Program::set(const char* n, float v) const { glProgramUniform1f(id(), location(n), v); }
void Program::set(const char* n, const glm::vec2& v) const {
    glProgramUniform2fv(id(), location(n), 1, glm::value_ptr(v));
}
void Program::set(const char* n, const glm::vec3& v) const {
    glProgramUniform3fv(id(), location(n), 1, glm::value_ptr(v));
}
void Program::set(const char* n, const glm::vec4& v) const {
    glProgramUniform4fv(id(), location(n), 1, glm::value_ptr(v));
}
void Program::set(const char* n, const glm::mat3& v) const {
    glProgramUniformMatrix3fv(id(), location(n), 1, GL_FALSE, glm::value_ptr(v));
}
void Program::set(const char* n, const glm::mat4& v) const {
    glProgramUniformMatrix4fv(id(), location(n), 1, GL_FALSE, glm::value_ptr(v));
}

}  // namespace nephele
