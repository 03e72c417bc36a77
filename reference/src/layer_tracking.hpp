// Tracking through the layers' volumes (nephele/layer_volume.hpp) for the path tracer: the
// layers' own majorant along a ray, free flights by delta tracking and transmittance by ratio
// tracking. Kept apart from the ellipsoids' trackers: the path tracer samples a free flight in
// each medium and takes the nearer (the first collision in a sum of media is the first of the
// collisions sampled in each), and multiplies the transmittances.
#pragma once

#include "tracking.hpp"

#include "nephele/layer_volume.hpp"

namespace nephele::detail {

// One ray's layer majorant (scratch space reused from ray to ray).
struct LayerRay {
    std::vector<LayerVolumes::Bound> bounds;
    std::vector<MajorantPiece> pieces;
    std::vector<std::pair<double, double>> events;
    std::vector<MajorantSegment> segs;
};

inline void prepareLayerRay(const LayerVolumes& v, const Vec3& eye, const Vec3& o, const Vec3& d, double t0, double t1,
                            LayerRay& r) {
    r.bounds.clear();
    v.majorant(o, d, t0, t1, eye, r.bounds);
    r.pieces.clear();
    for (const LayerVolumes::Bound& b : r.bounds) r.pieces.push_back({b.t0, b.t1, b.bound});
    buildMajorant(r.pieces, r.events, r.segs);
}

// The first real collision with the layers' matter along the prepared ray, or kNoCollision.
inline double layerFreeFlight(const LayerVolumes& v, const Vec3& eye, const Vec3& o, const Vec3& d, const LayerRay& r,
                              Pcg32& rng) {
    if (r.segs.empty()) return kNoCollision;
    return deltaTrack(
        r.segs, [&](double t) { return v.extinction(o + t * d, eye); }, rng);
}

// An unbiased estimate of the layers' transmittance along the prepared ray: ratio tracking,
// with Russian roulette once the estimate falls below 1% (a slab tens of km long would
// otherwise be walked to its end for nothing).
inline double layerTransmittance(const LayerVolumes& v, const Vec3& eye, const Vec3& o, const Vec3& d,
                                 const LayerRay& r, Pcg32& rng) {
    double transmittance = 1;
    for (const MajorantSegment& s : r.segs)
        for (double t = s.t0;;) {
            t -= std::log(1.0 - rng.uniform()) / s.majorant;
            if (t >= s.t1) break;
            transmittance *= std::max(0.0, 1.0 - v.extinction(o + t * d, eye) / s.majorant);
            if (transmittance < 0.01) {
                if (transmittance == 0 || rng.uniform() < 0.5) return 0;
                transmittance *= 2;
            }
        }
    return transmittance;
}

}  // namespace nephele::detail
