// OSMesa: Mesa's off-screen renderer, the fallback when EGL is not available.
#include "context_internal.hpp"

#include <GL/osmesa.h>

#include <vector>

namespace nephele::detail {
namespace {

void* osmesaLoader(const char* name) { return reinterpret_cast<void*>(OSMesaGetProcAddress(name)); }

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
        context_ = OSMesaCreateContextAttribs(attribs, nullptr);
        if (!context_)
            throw ContextError(
                "OSMesa backend: OSMesaCreateContextAttribs for OpenGL 4.5 core failed (this "
                "libOSMesa may be the old swrast build without core profiles). Try --gl egl, or "
                "install Mesa's gallium OSMesa (apt-get install libosmesa6; ./setup.sh does).");
        makeCurrent();
    }
    ~OSMesaContextImpl() override {
        if (OSMesaGetCurrentContext() == context_) OSMesaMakeCurrent(nullptr, nullptr, GL_UNSIGNED_BYTE, 0, 0);
        OSMesaDestroyContext(context_);
    }
    void makeCurrent() override {
        // Nephele renders into framebuffer objects; the default buffer is a 1x1 dummy.
        if (!OSMesaMakeCurrent(context_, buffer_.data(), GL_UNSIGNED_BYTE, 1, 1))
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
