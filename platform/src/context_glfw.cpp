// GLFW windows: Nephele::glfw, the one target that links GLFW. It defines
// nephele_create_glfw_context, which Context::create (Nephele::platform) calls for
// GlBackend::Glfw through a weak reference; Nephele::glfw's link option
// --undefined=nephele_create_glfw_context makes the linker keep this unit.
#include "context_internal.hpp"

#include "nephele/gl.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <mutex>
#include <string>

namespace nephele {
namespace {

std::mutex g_glfwMutex;
int g_glfwUsers = 0;
std::string g_glfwLastError;

void* glfwLoader(const char* name) { return reinterpret_cast<void*>(glfwGetProcAddress(name)); }

class GlfwContext final : public Context {
public:
    explicit GlfwContext(const ContextOptions& options) : Context(GlBackend::Glfw) {
        {
            std::lock_guard lock(g_glfwMutex);
            glfwSetErrorCallback([](int, const char* d) { g_glfwLastError = d ? d : ""; });
            if (g_glfwUsers == 0 && !glfwInit())
                throw ContextError("GLFW backend: glfwInit failed (" + g_glfwLastError +
                                   "). A window needs a display: set DISPLAY, or run under "
                                   "Xvfb (xvfb-run -a ...), or use --gl egl for headless rendering.");
            ++g_glfwUsers;
        }
        glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
        glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
        glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
        glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
        glfwWindowHint(GLFW_OPENGL_DEBUG_CONTEXT, options.debug ? GLFW_TRUE : GLFW_FALSE);
        glfwWindowHint(GLFW_VISIBLE, options.visible ? GLFW_TRUE : GLFW_FALSE);
        window_ = glfwCreateWindow(options.width, options.height, options.title.c_str(), nullptr, nullptr);
        if (!window_) {
            std::string why = g_glfwLastError;
            release();
            throw ContextError("GLFW backend: no OpenGL 4.5 core window (" + why +
                               "). Try --gl egl for headless rendering.");
        }
        makeCurrent();
    }
    ~GlfwContext() override {
        if (window_) glfwDestroyWindow(window_);
        release();
    }
    void makeCurrent() override {
        glfwMakeContextCurrent(window_);
        loadEntryPoints(&glfwLoader);
    }
    GLFWwindow* window() const override { return window_; }

private:
    static void release() {
        std::lock_guard lock(g_glfwMutex);
        if (--g_glfwUsers == 0) glfwTerminate();
    }
    GLFWwindow* window_ = nullptr;
};

}  // namespace
}  // namespace nephele

extern "C" nephele::Context* nephele_create_glfw_context(const nephele::ContextOptions* options) {
    return new nephele::GlfwContext(*options);
}
