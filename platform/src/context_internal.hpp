// Internal: the OSMesa context lives in its own unit because <GL/osmesa.h> pulls in
// <GL/gl.h>, which must not meet Nephele's own GL entry points.
#pragma once
#include "nephele/context.hpp"

namespace nephele {
using ProcLoaderFn = void* (*)(const char*);
namespace detail {
std::unique_ptr<Context> createOSMesaContext(const ContextOptions& options);
}  // namespace detail
}  // namespace nephele
