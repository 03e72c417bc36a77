#include "nephele/gl.hpp"

#include "nephele/resources.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <string>

namespace nephele::gl {

namespace {
std::atomic<bool> g_checks{NEPHELE_GL_CHECKS_DEFAULT != 0};
bool g_loaded = false;
}  // namespace

void load(ProcLoader loader) {
    if (!loader) throw GlError("gl::load: no getProcAddress function given");
    loader_detail::loadAllFunctions(loader);
    g_loaded = false;
    if (!glGetIntegerv || !glGetString || !glCreateBuffers)
        throw GlError("gl::load: the driver does not provide OpenGL 4.5 entry points");
    GLint major = 0, minor = 0;
    glGetIntegerv(GL_MAJOR_VERSION, &major);
    glGetIntegerv(GL_MINOR_VERSION, &minor);
    if (major * 10 + minor < 45) {
        const char* v = reinterpret_cast<const char*>(glGetString(GL_VERSION));
        throw GlError("OpenGL 4.5 core is required, the context is " + std::string(v ? v : "of unknown version") +
                      " (on Mesa, try --gl osmesa or set MESA_GL_VERSION_OVERRIDE=4.5)");
    }
    g_loaded = true;
}

bool isLoaded() { return g_loaded; }

void setChecks(bool enabled) { g_checks = enabled; }
bool checksEnabled() { return g_checks; }

const char* errorName(GLenum error) {
    switch (error) {
        case GL_NO_ERROR: return "GL_NO_ERROR";
        case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
        case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
        case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
        case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
        case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
        case GL_STACK_UNDERFLOW: return "GL_STACK_UNDERFLOW";
        case GL_STACK_OVERFLOW: return "GL_STACK_OVERFLOW";
        default: return "unknown GL error";
    }
}

void checkAlways(const char* what) {
    GLenum first = glGetError();
    if (first == GL_NO_ERROR) return;
    std::string msg = std::string(what) + ": " + errorName(first);
    // Drain the rest so the next check starts clean (bounded: a lost context repeats forever).
    for (int i = 0; i < 16; ++i) {
        GLenum more = glGetError();
        if (more == GL_NO_ERROR) break;
        msg += std::string(", ") + errorName(more);
    }
    throw GlError(msg);
}

void check(const char* what) {
    if (g_checks) checkAlways(what);
}

PartTimer::PartTimer(bool on) : on_(on) {
    if (on_) glFinish();
    last_ = std::chrono::steady_clock::now();
}

double PartTimer::lap() {
    if (!on_) return 0;
    glFinish();
    const auto now = std::chrono::steady_clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - last_).count();
    last_ = now;
    return ms;
}

void checkAllocation(const std::string& what, std::uint64_t bytes) {
    const GLenum first = glGetError();
    if (first == GL_NO_ERROR) return;
    for (int i = 0; i < 16 && glGetError() != GL_NO_ERROR; ++i) {}
    if (first == GL_OUT_OF_MEMORY)
        throw GlError(what + ": the driver could not allocate " + formatBytes(bytes) +
                      " (GL_OUT_OF_MEMORY); lower the image size or the setting that sizes it");
    throw GlError(what + " (" + formatBytes(bytes) + "): " + errorName(first));
}

std::string framebufferStatusName(GLenum status) {
    const char* name = "unknown status";
    switch (status) {
        case GL_FRAMEBUFFER_COMPLETE: name = "GL_FRAMEBUFFER_COMPLETE"; break;
        case GL_FRAMEBUFFER_UNDEFINED: name = "GL_FRAMEBUFFER_UNDEFINED"; break;
        case GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT: name = "GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT"; break;
        case GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT: name = "GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT"; break;
        case GL_FRAMEBUFFER_INCOMPLETE_DRAW_BUFFER: name = "GL_FRAMEBUFFER_INCOMPLETE_DRAW_BUFFER"; break;
        case GL_FRAMEBUFFER_INCOMPLETE_READ_BUFFER: name = "GL_FRAMEBUFFER_INCOMPLETE_READ_BUFFER"; break;
        case GL_FRAMEBUFFER_UNSUPPORTED: name = "GL_FRAMEBUFFER_UNSUPPORTED"; break;
        case GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE: name = "GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE"; break;
        case GL_FRAMEBUFFER_INCOMPLETE_LAYER_TARGETS: name = "GL_FRAMEBUFFER_INCOMPLETE_LAYER_TARGETS"; break;
        case 0: name = "glCheckFramebufferStatus failed"; break;
    }
    char hex[16];
    std::snprintf(hex, sizeof hex, "0x%04X", unsigned(status));
    return std::string(name) + " (" + hex + ")";
}

void checkFramebuffer(GLuint framebuffer, const std::string& what) {
    const GLenum status = glCheckNamedFramebufferStatus(framebuffer, GL_FRAMEBUFFER);
    if (status == GL_FRAMEBUFFER_COMPLETE) return;
    for (int i = 0; i < 16 && glGetError() != GL_NO_ERROR; ++i) {  // drained: the next check starts clean
    }
    throw GlError(what + ": framebuffer incomplete: " + framebufferStatusName(status) +
                  (status == GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT
                       ? " (the driver could not hold an attachment: lower the size)"
                       : ""));
}

void checkTextureSize(const std::string& what, int width, int height, int depth, int layers) {
    GLint max = 0;
    glGetIntegerv(depth > 0 ? GL_MAX_3D_TEXTURE_SIZE : GL_MAX_TEXTURE_SIZE, &max);
    const int largest = std::max({width, height, depth});
    std::string size =
        std::to_string(width) + "x" + std::to_string(height) + (depth > 0 ? "x" + std::to_string(depth) : "");
    if (std::min(width, height) < 1 || largest > max)
        throw GlError(what + ": a texture of " + size + " texels is outside this driver's " +
                      (depth > 0 ? "GL_MAX_3D_TEXTURE_SIZE " : "GL_MAX_TEXTURE_SIZE ") + std::to_string(max));
    if (layers > 0) {
        glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max);
        if (layers > max)
            throw GlError(what + ": " + std::to_string(layers) +
                          " layers are over this driver's GL_MAX_ARRAY_TEXTURE_LAYERS " + std::to_string(max));
    }
}

namespace kind {
GLuint Buffer::create() {
    GLuint id = 0;
    glCreateBuffers(1, &id);
    return id;
}
void Buffer::destroy(GLuint id) { glDeleteBuffers(1, &id); }
GLuint VertexArray::create() {
    GLuint id = 0;
    glCreateVertexArrays(1, &id);
    return id;
}
void VertexArray::destroy(GLuint id) { glDeleteVertexArrays(1, &id); }
GLuint Texture::create(GLenum target) {
    GLuint id = 0;
    glCreateTextures(target, 1, &id);
    return id;
}
void Texture::destroy(GLuint id) { glDeleteTextures(1, &id); }
GLuint Renderbuffer::create() {
    GLuint id = 0;
    glCreateRenderbuffers(1, &id);
    return id;
}
void Renderbuffer::destroy(GLuint id) { glDeleteRenderbuffers(1, &id); }
GLuint Framebuffer::create() {
    GLuint id = 0;
    glCreateFramebuffers(1, &id);
    return id;
}
void Framebuffer::destroy(GLuint id) { glDeleteFramebuffers(1, &id); }
GLuint Sampler::create() {
    GLuint id = 0;
    glCreateSamplers(1, &id);
    return id;
}
void Sampler::destroy(GLuint id) { glDeleteSamplers(1, &id); }
GLuint Query::create(GLenum target) {
    GLuint id = 0;
    glCreateQueries(target, 1, &id);
    return id;
}
void Query::destroy(GLuint id) { glDeleteQueries(1, &id); }
GLuint Shader::create(GLenum stage) { return glCreateShader(stage); }
void Shader::destroy(GLuint id) { glDeleteShader(id); }
GLuint Program::create() { return glCreateProgram(); }
void Program::destroy(GLuint id) { glDeleteProgram(id); }
}  // namespace kind

IndexedMesh makeIndexedMesh(const std::vector<float>& v, const std::vector<unsigned>& idx, int attributes) {
    IndexedMesh m;
    m.vao = VertexArray::create();
    m.vertices = Buffer::create();
    m.indices = Buffer::create();
    glNamedBufferStorage(m.vertices.id(), GLsizeiptr(v.size() * sizeof(float)), v.data(), 0);
    glNamedBufferStorage(m.indices.id(), GLsizeiptr(idx.size() * sizeof(unsigned)), idx.data(), 0);
    glVertexArrayVertexBuffer(m.vao.id(), 0, m.vertices.id(), 0, GLsizei(attributes * 3 * sizeof(float)));
    glVertexArrayElementBuffer(m.vao.id(), m.indices.id());
    for (GLuint a = 0; a < GLuint(attributes); ++a) {
        glEnableVertexArrayAttrib(m.vao.id(), a);
        glVertexArrayAttribFormat(m.vao.id(), a, 3, GL_FLOAT, GL_FALSE, a * 3 * sizeof(float));
        glVertexArrayAttribBinding(m.vao.id(), a, 0);
    }
    m.indexCount = GLsizei(idx.size());
    return m;
}

void uploadDynamic(Buffer& buffer, std::size_t& capacity, const void* data, std::size_t bytes) {
    // The storage is at least 16 bytes (an empty SSBO binding is an error), but only the
    // caller's `bytes` are read from `data`: copying the padded size read past a short buffer.
    const std::size_t storage = std::max<std::size_t>(bytes, 16);
    if (!buffer || capacity < storage) {
        buffer = Buffer::create();
        capacity = std::max(storage, capacity * 2);
        glNamedBufferStorage(buffer.id(), GLsizeiptr(capacity), nullptr, GL_DYNAMIC_STORAGE_BIT);
    }
    if (data && bytes > 0) glNamedBufferSubData(buffer.id(), 0, GLsizeiptr(bytes), data);
}

Sampler linearSampler(GLenum wrap) {
    Sampler s = Sampler::create();
    glSamplerParameteri(s.id(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glSamplerParameteri(s.id(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
        glSamplerParameteri(s.id(), w, GLint(wrap));
    return s;
}

}  // namespace nephele::gl
