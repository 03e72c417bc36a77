// What a shared Nephele exports. The libraries are compiled with hidden symbols
// (-fvisibility=hidden); every public header (and each shared internal header, which other
// Nephele libraries call across a library boundary) wraps its declarations in
// NEPHELE_API_BEGIN ... NEPHELE_API_END, so that exactly what they declare is exported from
// libnephele_*.so and nothing of a library's src/. Static libraries are unaffected.
// tools/check_layout.py checks that every such header has the pair.
#pragma once

#if defined(__GNUC__) || defined(__clang__)
#define NEPHELE_API_BEGIN _Pragma("GCC visibility push(default)")
#define NEPHELE_API_END _Pragma("GCC visibility pop")
#else
#define NEPHELE_API_BEGIN
#define NEPHELE_API_END
#endif
