// OpenGL 4.5 core contexts: headless EGL (default), OSMesa (fallback), GLFW (windows).
// A host that owns its context needs none of this: it calls nephele::gl::load() once.
#pragma once

#include "nephele/api.hpp"
#include <memory>
#include <stdexcept>
#include <string>

struct GLFWwindow;

NEPHELE_API_BEGIN
namespace nephele {

enum class GlBackend { Egl, OSMesa, Glfw };
const char* backendName(GlBackend backend);       // "egl", "osmesa", "glfw"
GlBackend parseBackend(const std::string& name);  // throws std::invalid_argument

// A context could not be made. what() says which backend failed, why, and what to try.
class ContextError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct ContextOptions {
    GlBackend backend = GlBackend::Egl;
    int width = 640;  // GLFW window size; EGL and OSMesa render to framebuffer objects
    int height = 480;
    bool visible = true;  // GLFW only
    std::string title = "Nephele";
    bool debug = false;  // request a debug context
};

class Context {
public:
    // Makes the context, makes it current and loads the GL entry points for it.
    static std::unique_ptr<Context> create(const ContextOptions& options);
    virtual ~Context() = default;
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    // Makes it current on this thread (and reloads entry points if another backend's
    // context was current before).
    virtual void makeCurrent() = 0;
    virtual GLFWwindow* window() const { return nullptr; }
    GlBackend backend() const { return backend_; }
    // "OpenGL 4.5 (Core Profile) Mesa 22.3.6, llvmpipe (LLVM 15.0.6, 256 bits)"
    std::string description() const;

protected:
    explicit Context(GlBackend backend) : backend_(backend) {}
    void loadEntryPoints(void* (*loader)(const char*));

private:
    GlBackend backend_;
};

}  // namespace nephele
NEPHELE_API_END
