// OSMesa: Mesa's off-screen renderer, the fallback when EGL is not available. libOSMesa is
// opened when the first OSMesa context is made, not linked: it brings a second Mesa and LLVM
// with it, which every program linking Nephele::platform would otherwise load at start (time
// and memory; docs/testing.md) whether it ever used OSMesa or not.
#include "context_internal.hpp"

#include <GL/osmesa.h>
#include <dlfcn.h>

#include <string>
#include <vector>

namespace nephele::detail {
namespace {

// OSMesa's entry points, from the library opened once and kept open for the process's life (a
// context's driver code must outlive every context, and LeakSanitizer names what Mesa keeps
// only while it is loaded).
struct OSMesaApi {
    decltype(&OSMesaCreateContextAttribs) createContextAttribs = nullptr;
    decltype(&OSMesaMakeCurrent) makeCurrent = nullptr;
    decltype(&OSMesaGetCurrentContext) getCurrentContext = nullptr;
    decltype(&OSMesaDestroyContext) destroyContext = nullptr;
    decltype(&OSMesaGetProcAddress) getProcAddress = nullptr;
};

template <class F>
void bind(void* library, F& f, const char* name) {
    f = reinterpret_cast<F>(dlsym(library, name));
    if (!f)
        throw ContextError(std::string("OSMesa backend: the OSMesa library has no ") + name +
                           " (an old libOSMesa?). Try --gl egl, or install Mesa's gallium OSMesa (apt-get "
                           "install libosmesa6; ./setup.sh does).");
}

const OSMesaApi& osmesa() {
    static const OSMesaApi api = [] {
        void* library = nullptr;
        std::string why;
        for (const char* name : {"libOSMesa.so.8", "libOSMesa.so"}) {
            if ((library = dlopen(name, RTLD_NOW | RTLD_LOCAL))) break;
            const char* e = dlerror();
            why += std::string(why.empty() ? "" : "; ") + (e ? e : name);
        }
        if (!library)
            throw ContextError("OSMesa backend: libOSMesa could not be loaded (" + why +
                               "). Try --gl egl, or install it (apt-get install libosmesa6; ./setup.sh does).");
        OSMesaApi a;
        bind(library, a.createContextAttribs, "OSMesaCreateContextAttribs");
        bind(library, a.makeCurrent, "OSMesaMakeCurrent");
        bind(library, a.getCurrentContext, "OSMesaGetCurrentContext");
        bind(library, a.destroyContext, "OSMesaDestroyContext");
        bind(library, a.getProcAddress, "OSMesaGetProcAddress");
        return a;
    }();
    return api;
}

void* osmesaLoader(const char* name) { return reinterpret_cast<void*>(osmesa().getProcAddress(name)); }

class OSMesaContextImpl final : public Context {
public:
    explicit OSMesaContextImpl(const ContextOptions&) : Context(GlBackend::OSMesa) {
        const int attribs[] = {OSMESA_FORMAT,
                               OSMESA_RGBA,
                               OSMESA_DEPTH_BITS,
                               24,
                               OSMESA_STENCIL_BITS,
                               8,
                               OSMESA_PROFILE,
                               OSMESA_CORE_PROFILE,
                               OSMESA_CONTEXT_MAJOR_VERSION,
                               4,
                               OSMESA_CONTEXT_MINOR_VERSION,
                               5,
                               0};
        context_ = osmesa().createContextAttribs(attribs, nullptr);
        if (!context_)
            throw ContextError(
                "OSMesa backend: OSMesaCreateContextAttribs for OpenGL 4.5 core failed (this "
                "libOSMesa may be the old swrast build without core profiles). Try --gl egl, or "
                "install Mesa's gallium OSMesa (apt-get install libosmesa6; ./setup.sh does).");
        makeCurrent();
    }
    ~OSMesaContextImpl() override {
        const OSMesaApi& api = osmesa();
        if (api.getCurrentContext() == context_) api.makeCurrent(nullptr, nullptr, GL_UNSIGNED_BYTE, 0, 0);
        api.destroyContext(context_);
    }
    void makeCurrent() override {
        // Nephele renders into framebuffer objects; the default buffer is a 1x1 dummy.
        if (!osmesa().makeCurrent(context_, buffer_.data(), GL_UNSIGNED_BYTE, 1, 1))
            throw ContextError("OSMesa backend: OSMesaMakeCurrent failed. Try --gl egl.");
        loadEntryPoints(&osmesaLoader);
    }

private:
    OSMesaContext context_ = nullptr;
    std::vector<unsigned char> buffer_ = std::vector<unsigned char>(4, 0);
};

}  // namespace

std::unique_ptr<Context> createOSMesaContext(const ContextOptions& options) {
    return std::make_unique<OSMesaContextImpl>(options);
}

}  // namespace nephele::detail
