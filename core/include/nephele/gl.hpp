// Nephele's GL layer: entry points, error checks, move-only RAII handles.
//
// The entry points are function pointers in namespace nephele::gl (generated from
// glcorearb.h), so a translation unit that says `using namespace nephele::gl;` calls
// glClear(...) as usual without ever clashing with the host's libGL. Do not include
// <GL/gl.h> in such a unit.
#pragma once

#include "nephele/api.hpp"
#include "nephele/gl_functions.hpp"

#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele::gl {

using ProcLoader = void* (*)(const char*);

// A GL call failed (glGetError), a required feature is missing, or a resource could not
// be made. what() names the operation and the GL error.
class GlError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Loads every entry point through `loader` for the context current on this thread and
// checks that it is OpenGL 4.5 or newer. Throws GlError otherwise. Contexts made by
// nephele::Context call this themselves; a host with its own context calls it once.
void load(ProcLoader loader);
bool isLoaded();

// Error checks after draws and passes: on by default when built with NEPHELE_GL_CHECKS
// (the default), always on in the tests. check() throws GlError("<what>: GL_INVALID_ENUM").
void setChecks(bool enabled);
bool checksEnabled();
void check(const char* what);
// Drains glGetError unconditionally and throws if any error was pending.
void checkAlways(const char* what);
const char* errorName(GLenum error);

// Wall time of GL work by part, for the timings a host asks for (SkySettings::timings):
// lap() waits for the GL work issued so far (glFinish) and returns the milliseconds since
// the previous lap (or construction). Off, lap() returns 0 and never waits. GL timer
// queries are no use here: llvmpipe's GL_TIME_ELAPSED leaves out the work a pass hands to
// its rasterizer threads, a fraction of what the pass takes to finish.
class PartTimer {
public:
    explicit PartTimer(bool on);
    double lap();

private:
    bool on_;
    std::chrono::steady_clock::time_point last_;
};

// GL faults of allocation, checked whatever setChecks() says (a failed allocation must end in
// a message, never in a draw into nothing or an abort):
// After allocating GL storage of about `bytes` (a texture, a buffer): throws GlError("WHAT: the
// driver could not allocate 3.2 GB (GL_OUT_OF_MEMORY); ..."), or names any other pending error.
void checkAllocation(const std::string& what, std::uint64_t bytes);
// Throws GlError("WHAT: framebuffer incomplete: GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT (0x8CD6)")
// unless `framebuffer` is complete (a driver may refuse an attachment it cannot hold).
void checkFramebuffer(GLuint framebuffer, const std::string& what);
// "GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT (0x8CD6)", any status in hexadecimal.
std::string framebufferStatusName(GLenum status);
// Throws GlError naming WHAT, the size and the limit when a texture of width x height (x depth
// for 3D) is over GL_MAX_TEXTURE_SIZE (GL_MAX_3D_TEXTURE_SIZE when depth > 0, and
// GL_MAX_ARRAY_TEXTURE_LAYERS for `layers` > 0).
void checkTextureSize(const std::string& what, int width, int height, int depth = 0, int layers = 0);

// A move-only owner of one GL object name: copy deleted, move noexcept, a moved-from
// handle holds 0. wrap() adopts a name, release() hands it back without deleting.
template <class Kind>
class Handle {
public:
    Handle() noexcept = default;
    template <class... Args>
    static Handle create(Args... args) {
        return Handle(Kind::create(args...));
    }
    static Handle wrap(GLuint id) noexcept { return Handle(id); }

    ~Handle() { reset(); }
    Handle(Handle&& other) noexcept : id_(std::exchange(other.id_, 0)) {}
    Handle& operator=(Handle&& other) noexcept {
        if (this != &other) {
            reset();
            id_ = std::exchange(other.id_, 0);
        }
        return *this;
    }
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;

    GLuint id() const noexcept { return id_; }
    explicit operator bool() const noexcept { return id_ != 0; }
    GLuint release() noexcept { return std::exchange(id_, 0); }
    void reset() noexcept {
        if (id_ != 0) Kind::destroy(id_);
        id_ = 0;
    }

private:
    explicit Handle(GLuint id) noexcept : id_(id) {}
    GLuint id_ = 0;
};

namespace kind {
struct Buffer {
    static GLuint create();
    static void destroy(GLuint);
};
struct VertexArray {
    static GLuint create();
    static void destroy(GLuint);
};
struct Texture {
    static GLuint create(GLenum target);
    static void destroy(GLuint);
};
struct Renderbuffer {
    static GLuint create();
    static void destroy(GLuint);
};
struct Framebuffer {
    static GLuint create();
    static void destroy(GLuint);
};
struct Sampler {
    static GLuint create();
    static void destroy(GLuint);
};
struct Query {
    static GLuint create(GLenum target);
    static void destroy(GLuint);
};
struct Shader {
    static GLuint create(GLenum stage);
    static void destroy(GLuint);
};
struct Program {
    static GLuint create();
    static void destroy(GLuint);
};
}  // namespace kind

using Buffer = Handle<kind::Buffer>;
using VertexArray = Handle<kind::VertexArray>;
using Texture = Handle<kind::Texture>;
using Renderbuffer = Handle<kind::Renderbuffer>;
using Framebuffer = Handle<kind::Framebuffer>;
using Sampler = Handle<kind::Sampler>;
using Query = Handle<kind::Query>;
using ShaderObject = Handle<kind::Shader>;
using ProgramObject = Handle<kind::Program>;

// Indexed triangles with `attributes` interleaved vec3 attributes per vertex (locations
// 0, 1, ...: e.g. position, normal), in immutable buffers.
struct IndexedMesh {
    VertexArray vao;
    Buffer vertices, indices;
    GLsizei indexCount = 0;
};
IndexedMesh makeIndexedMesh(const std::vector<float>& interleaved, const std::vector<unsigned>& indices,
                            int attributes);

// Storage that is rewritten every frame: grows `buffer` (doubling, never shrinking) to hold
// `bytes` (at least 16) and copies exactly `bytes` of `data` in (nothing when data is null).
void uploadDynamic(Buffer& buffer, std::size_t& capacity, const void* data, std::size_t bytes);

// A sampler with linear filtering and the same wrap mode on s, t and r.
Sampler linearSampler(GLenum wrap);

}  // namespace nephele::gl
NEPHELE_API_END
