// A 64-bit FNV-1a fingerprint of what a cached result depends on (light volumes, reference
// images): add every input, compare values. Not cryptographic.
#pragma once

#include "nephele/api.hpp"
#include "nephele/scene.hpp"

#include <cstdint>
#include <string>
#include <type_traits>

NEPHELE_API_BEGIN
namespace nephele {

class Fingerprint {
public:
    Fingerprint& bytes(const void* data, std::size_t size) {
        for (std::size_t i = 0; i < size; ++i)
            value_ = (value_ ^ static_cast<const unsigned char*>(data)[i]) * 1099511628211ull;
        return *this;
    }
    template <class T>
    Fingerprint& add(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        return bytes(&v, sizeof v);
    }
    Fingerprint& add(const std::string& s) { return add(s.size()).bytes(s.data(), s.size()); }
    // Every ellipsoid of every cloud (centres, radii, rotations, densities).
    Fingerprint& addClouds(const std::vector<Cloud>& clouds) {
        add(clouds.size());
        for (const Cloud& c : clouds) {
            add(c.ellipsoids.size());
            for (const Ellipsoid& e : c.ellipsoids) add(e.center).add(e.radii).add(e.rotationDeg).add(e.density);
        }
        return *this;
    }
    Fingerprint& addMedium(const Medium& m) {
        return add(m.extinction).add(m.albedo).add(m.hgG).add(m.noise).add(m.noiseScale);
    }
    // medium.detail without its drift (what the field is, not where the wind has carried it).
    Fingerprint& addDetail(const Medium::Detail& d) {
        return add(d.kind).add(d.erosion).add(d.scale).add(d.smallest).add(d.wind);
    }
    std::uint64_t value() const { return value_; }

private:
    std::uint64_t value_ = 1469598103934665603ull;
};

}  // namespace nephele
NEPHELE_API_END
