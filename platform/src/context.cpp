#include "nephele/context.hpp"

#include "context_internal.hpp"
#include "nephele/gl.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstring>
#include <string>

#pragma weak nephele_create_glfw_context

namespace nephele {

const char* backendName(GlBackend backend) {
    switch (backend) {
        case GlBackend::Egl: return "egl";
        case GlBackend::OSMesa: return "osmesa";
        case GlBackend::Glfw: return "glfw";
    }
    return "?";
}

GlBackend parseBackend(const std::string& name) {
    if (name == "egl") return GlBackend::Egl;
    if (name == "osmesa") return GlBackend::OSMesa;
    if (name == "glfw") return GlBackend::Glfw;
    throw std::invalid_argument("unknown GL backend '" + name + "' (expected egl, osmesa or glfw)");
}

namespace {
// The loader whose entry points are in nephele::gl now. Contexts of one backend share
// entry points (EGL and GLFW return context-independent dispatch stubs on Mesa); a switch
// to another backend reloads them.
ProcLoaderFn g_loadedWith = nullptr;
}  // namespace

void Context::loadEntryPoints(ProcLoaderFn loader) {
    if (g_loadedWith == loader && gl::isLoaded()) return;
    try {
        gl::load(loader);
    } catch (const gl::GlError& e) {
        g_loadedWith = nullptr;
        throw ContextError(std::string(backendName(backend_)) + ": " + e.what());
    }
    g_loadedWith = loader;
}

std::string Context::description() const {
    auto str = [](GLenum name) {
        const GLubyte* s = gl::glGetString(name);
        return s ? std::string(reinterpret_cast<const char*>(s)) : std::string("?");
    };
    return "OpenGL " + str(GL_VERSION) + ", " + str(GL_RENDERER);
}

// ---------------------------------------------------------------- EGL (headless)
namespace {

const char* eglErrorName(EGLint e) {
    switch (e) {
        case EGL_SUCCESS: return "EGL_SUCCESS";
        case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
        case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
        case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
        case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
        case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
        case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
        case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
        case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
        case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
        case EGL_BAD_SURFACE: return "EGL_BAD_SURFACE";
        default: return "EGL error";
    }
}

bool hasExtension(const char* list, const char* name) {
    if (!list) return false;
    const size_t n = std::strlen(name);
    for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n)
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
    return false;
}

void* eglLoader(const char* name) { return reinterpret_cast<void*>(eglGetProcAddress(name)); }

const char* kEglHint =
    " Try --gl osmesa, or install Mesa's EGL driver (apt-get install libegl-mesa0 "
    "libgl1-mesa-dri; ./setup.sh does).";

class EglContext final : public Context {
public:
    explicit EglContext(const ContextOptions& options) : Context(GlBackend::Egl) {
        display_ = openDisplay();
        EGLint major = 0, minor = 0;
        if (!eglInitialize(display_, &major, &minor))
            fail("eglInitialize failed (" + std::string(eglErrorName(eglGetError())) + ")");
        const char* ext = eglQueryString(display_, EGL_EXTENSIONS);
        if (!hasExtension(ext, "EGL_KHR_surfaceless_context"))
            fail("the EGL display lacks EGL_KHR_surfaceless_context");
        if (!eglBindAPI(EGL_OPENGL_API)) fail("the EGL display does not support desktop OpenGL");

        EGLConfig config = EGL_NO_CONFIG_KHR;
        if (!hasExtension(ext, "EGL_KHR_no_config_context")) {
            const EGLint want[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
            EGLint count = 0;
            if (!eglChooseConfig(display_, want, &config, 1, &count) || count < 1)
                fail("no EGL config supports desktop OpenGL");
        }
        const EGLint attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                  4,
                                  EGL_CONTEXT_MINOR_VERSION,
                                  5,
                                  EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                  EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                  EGL_CONTEXT_OPENGL_DEBUG,
                                  options.debug ? EGL_TRUE : EGL_FALSE,
                                  EGL_NONE};
        context_ = eglCreateContext(display_, config, EGL_NO_CONTEXT, attribs);
        if (context_ == EGL_NO_CONTEXT)
            fail("eglCreateContext for OpenGL 4.5 core failed (" + std::string(eglErrorName(eglGetError())) + ")");
        makeCurrent();
    }
    ~EglContext() override {
        if (context_ != EGL_NO_CONTEXT) {
            if (eglGetCurrentContext() == context_)
                eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
            eglDestroyContext(display_, context_);
        }
        // The display is shared by every EGL context of the process: it is not terminated.
    }
    void makeCurrent() override {
        if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
            fail("eglMakeCurrent failed (" + std::string(eglErrorName(eglGetError())) + ")");
        loadEntryPoints(&eglLoader);
    }

private:
    [[noreturn]] void fail(const std::string& why) { throw ContextError("EGL backend: " + why + "." + kEglHint); }
    // Mesa's surfaceless platform first (no GPU, no display server), then the device
    // platform (a GPU without a display server), then the default display.
    EGLDisplay openDisplay() {
        const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
        if (hasExtension(client, "EGL_MESA_platform_surfaceless")) {
            EGLDisplay d = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
            if (d != EGL_NO_DISPLAY) return d;
        }
        if (hasExtension(client, "EGL_EXT_platform_device")) {
            auto queryDevices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
            EGLDeviceEXT devices[8];
            EGLint n = 0;
            if (queryDevices && queryDevices(8, devices, &n) && n > 0) {
                EGLDisplay d = eglGetPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices[0], nullptr);
                if (d != EGL_NO_DISPLAY) return d;
            }
        }
        EGLDisplay d = eglGetDisplay(EGL_DEFAULT_DISPLAY);
        if (d == EGL_NO_DISPLAY) fail("no EGL display (neither surfaceless, device nor default)");
        return d;
    }

    EGLDisplay display_ = EGL_NO_DISPLAY;
    EGLContext context_ = EGL_NO_CONTEXT;
};

}  // namespace

std::unique_ptr<Context> Context::create(const ContextOptions& options) {
    switch (options.backend) {
        case GlBackend::Egl: return std::make_unique<EglContext>(options);
        case GlBackend::OSMesa: return detail::createOSMesaContext(options);
        case GlBackend::Glfw:
            // Defined by Nephele::glfw when the program links it (a weak reference otherwise).
            if (!nephele_create_glfw_context)
                throw ContextError(
                    "GLFW backend: this program was built without windows (it does not link "
                    "Nephele::glfw). Use --gl egl for headless rendering.");
            return std::unique_ptr<Context>(nephele_create_glfw_context(&options));
    }
    throw ContextError("unknown GL backend");
}

}  // namespace nephele
