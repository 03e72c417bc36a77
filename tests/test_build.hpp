// What build the tests run in. The sanitizer build (CMake option NEPHELE_SANITIZE, .ci/run's
// second tree) runs 2-4x slower, and cannot run under an address-space cap: AddressSanitizer
// reserves terabytes of shadow address space at start-up.
#pragma once

namespace nephele::test {

#ifdef NEPHELE_TEST_SANITIZED
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif

// Tests' bounds on CPU and wall time are multiplied by this. Measured under ASan + UBSan on
// this 2-core machine beside another test (ctest -j2): loading 200k ellipsoids 1 s -> 8.6 s,
// the scale bench's quick run and the hostile-input runs 3-4x.
inline constexpr double kTimeScale = kSanitized ? 4.0 : 1.0;

// Added to tests' bounds on a child's peak resident memory. AddressSanitizer's shadow memory,
// quarantine and runtime raise every process's floor: `nephele compare` refusing two images by
// their headers peaks at 60 MB in the release build and 122 MB under ASan + UBSan.
inline constexpr double kMemoryOverheadMb = kSanitized ? 150.0 : 0.0;

}  // namespace nephele::test
