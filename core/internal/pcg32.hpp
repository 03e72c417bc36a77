// PCG32 (O'Neill 2014): 64-bit LCG state, XSH-RR output, and the SplitMix64 finaliser that
// seeds it: the one generator of the path tracer (reference/src/tracking.hpp) and of the photon
// tracers (model/internal/phase_sampling.hpp). Internal to the libraries.
#pragma once

#include "nephele/api.hpp"
#include <cstdint>

NEPHELE_API_BEGIN
namespace nephele::detail {

class Pcg32 {
public:
    // PCG's srandom: the stream, then the state added between two steps.
    Pcg32(std::uint64_t state, std::uint64_t stream) : inc_((stream << 1) | 1u) {
        next();
        state_ += state;
        next();
    }
    // The state and the stream as they are, no step.
    static Pcg32 raw(std::uint64_t state, std::uint64_t stream) {
        Pcg32 r;
        r.state_ = state, r.inc_ = (stream << 1) | 1u;
        return r;
    }
    std::uint32_t next() {
        const std::uint64_t old = state_;
        state_ = old * 6364136223846793005ull + inc_;
        const auto xorshifted = std::uint32_t(((old >> 18) ^ old) >> 27);
        const auto rot = std::uint32_t(old >> 59);
        return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
    }
    double uniform() { return next() * 0x1.0p-32; }              // [0, 1)
    double uniformOpen() { return (next() + 0.5) * 0x1.0p-32; }  // (0, 1)

private:
    Pcg32() = default;
    std::uint64_t state_ = 0, inc_ = 1;
};

// SplitMix64 finaliser: a well-mixed 64-bit hash.
inline std::uint64_t mix64(std::uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

}  // namespace nephele::detail
NEPHELE_API_END
