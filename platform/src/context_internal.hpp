// Internal: the contexts of each backend in their own units. OSMesa because <GL/osmesa.h>
// pulls in <GL/gl.h>, which must not meet Nephele's own GL entry points; GLFW because it is
// a library of its own (Nephele::glfw).
#pragma once
#include "nephele/context.hpp"

namespace nephele {
using ProcLoaderFn = void* (*)(const char*);
namespace detail {
std::unique_ptr<Context> createOSMesaContext(const ContextOptions& options);
}  // namespace detail
}  // namespace nephele

// Nephele::glfw's GLFW context (context_glfw.cpp); Context::create refers to it weakly, so that
// a program without Nephele::glfw links no GLFW. Throws ContextError.
extern "C" nephele::Context* nephele_create_glfw_context(const nephele::ContextOptions* options);
