// Sanitizer builds only (NEPHELE_SANITIZE): keeps Mesa's DRI driver mapped until the process
// exits. GLX unloads swrast_dri.so when a GLFW window's display closes, and LeakSanitizer can
// then no longer name the module of the allocations the driver leaves behind: they show as
// "<unknown module>", and lsan.supp's `leak:swrast_dri.so` could not match them. Loading it
// once with RTLD_NODELETE changes nothing else: GLX and EGL get this same copy.
#include <dlfcn.h>

namespace {
[[maybe_unused]] void* const kKeptDriver = ::dlopen(NEPHELE_DRI_DIR "/swrast_dri.so", RTLD_NOW | RTLD_NODELETE);
}  // namespace
