// The ellipsoid clouds' matter as the path tracer holds it, at a point and along a ray: one
// source for the path tracer (reference/), the cloud queries of the host API (sky/) and the
// exports of the field. The extinction (1/m) at a world point x is
//   sigma(x) = sum_i w_i sigma_i phi_i(x) N_i(x)
// over the ellipsoids i, with
//   sigma_i = min(medium.extinction * density_i, maxOpticalDepth / (16/15 r_min,i)): the cap
//             keeps the optical depth through the centre along the shortest axis at most
//             maxOpticalDepth (beyond it an ellipsoid is opaque in double precision);
//   phi_i   = (1 - q_i)^2, q_i the squared unit-space radius of x (eq. 1), or with the detail
//             (nephele/detail.hpp) max(1 - q_i (1 + delta(x))^2, 0)^2;
//   N_i     = max(0, 1 + medium.noise n(x / period + offset_i)) with the noise volume's n, period
//             medium.noise_scale * NoiseSettings::cells and offset_i ellipsoidNoiseOffset(cloud or
//             Cloud::noiseId, index, NoiseSettings::seed), as every method reads the noise;
//   w_i     = the ellipsoid's Cloud::weight when made with `weights`, else 1 (the path tracer
//             draws every cloud whole).
// The detail's erosion delta(x) depends on the eye (its octaves fade with distance): a
// DetailFrame carries it; the one given at construction is the default.
#pragma once

#include "nephele/api.hpp"
#include "nephele/detail.hpp"
#include "nephele/noise.hpp"
#include "nephele/scene.hpp"

#include <algorithm>
#include <span>
#include <utility>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

// The cap of an ellipsoid's optical depth through its centre along its shortest axis, as the
// path tracer holds it (nephele/pathtrace.hpp).
inline constexpr double kMaxOpticalDepth = 1e12;

class CloudMatter {
public:
    // The eye the detail is seen from (m, world) and the detail's parameters for it.
    struct DetailFrame {
        model::DetailParams params{};  // erosion 0: the detail is off
        Vec3 eye{0.0};
    };

    // The matter of scene.clouds (ellipsoids of density > 0) in scene.medium, the detail seen
    // from `eye`. `noise` (kept by pointer: it must outlive this) is needed when medium.noise > 0
    // (std::invalid_argument otherwise); ellipsoids are not validated (the loader did; the path
    // tracer checks a scene built in code first).
    CloudMatter(const Scene& scene, const NoiseVolume* noise, const Vec3& eye, double maxOpticalDepth, bool weights);

    // The same matter with the detail seen from another eye.
    DetailFrame detailFrame(const Vec3& eye) const;
    const DetailFrame& defaultFrame() const { return frame_; }

    // The extinction at the point x (1/m). Thread-safe (const).
    double extinction(const Vec3& x) const { return extinction(x, frame_); }
    double extinction(const Vec3& x, const DetailFrame& frame) const;

    // A ray o + t d's chord through ellipsoid `shape`: in unit space the ray is at arc length
    // u = t len - tc from its closest approach to the centre, at squared distance q = b2 + u^2.
    struct Chord {
        double tIn, tOut;  // m, the chord clipped to the ray's interval
        double len;        // |M d|: unit-space length per metre
        double tc;         // unit-space arc length of the closest approach
        double b2;         // squared impact parameter, < 1
        int shape;
    };
    // The chords of o + t d (unit d) within [t0, t1] (a BVH over the ellipsoids' world boxes),
    // sorted by entry; `out` is cleared first.
    void chords(const Vec3& o, const Vec3& d, double t0, double t1, std::vector<Chord>& out) const;
    // The run of overlapping chords that starts at `first` of chords() (sorted by entry): it ends
    // before the returned index; `tOut` receives where it leaves the last of them.
    static std::size_t runEnd(std::span<const Chord> chords, std::size_t first, double& tOut) {
        tOut = chords[first].tOut;
        std::size_t end = first + 1;
        for (; end < chords.size() && chords[end].tIn <= tOut; ++end) tOut = std::max(tOut, chords[end].tOut);
        return end;
    }
    // The extinction at o + t d from the ray's chords (the same value as extinction(o + t d)).
    // Any run of them, in their order, will do.
    double extinctionAlong(const Vec3& o, const Vec3& d, double t, std::span<const Chord> chords) const {
        return extinctionAlong(o, d, t, chords, frame_);
    }
    double extinctionAlong(const Vec3& o, const Vec3& d, double t, std::span<const Chord> chords,
                           const DetailFrame& frame) const;
    // The smooth field's optical depth over [t0, t1] (no noise, no detail: exact, closed form
    // per chord, model::segmentDepth); the chords from chords() over an interval holding [t0, t1].
    double smoothDepth(const Vec3& o, const Vec3& d, double t0, double t1, const std::vector<Chord>& chords) const;
    // The same for one chord, over [t0, t1].
    double smoothDepth(const Vec3& o, const Vec3& d, double t0, double t1, const Chord& chord) const;
    // The chord's own ellipsoid's smooth extinction sigma_i w_i (1 - q)^2 at o + t d.
    double chordSmooth(double t, const Chord& chord) const;

    // sigma_i w_i of one ellipsoid (1/m), and a bound of the noise factor N_i (1 without noise).
    double sigma(int shape) const { return shapes_[std::size_t(shape)].sigma; }
    double noiseBound() const { return noiseBound_; }
    // The field is not the smooth one (noise or detail): no closed form along a ray.
    bool varies() const { return amp_ > 0 || detailOn(); }
    bool detailOn() const { return frame_.params.erosion > 0; }
    bool empty() const { return shapes_.empty(); }
    int size() const { return int(shapes_.size()); }
    // The world box outside which there is no matter (lo > hi when there is none).
    std::pair<Vec3, Vec3> bounds() const;

private:
    struct Shape {
        glm::dmat3 unit{1.0};         // M = diag(1/r) R^T: world offset -> unit sphere
        Vec3 center{0.0};             // m
        double sigma = 0;             // 1/m, capped, times the weight
        Vec3 lo{0.0}, hi{0.0};        // m, world bounding box
        glm::vec3 noiseOffset{0.0f};  // noise-volume texture coordinates (periods)
    };
    struct Node {
        Vec3 lo{0.0}, hi{0.0};
        int first = 0, count = 0;  // a leaf: shapes [first, first + count); else children at index+1 and `second`
        int second = 0;
    };
    double matter(const Shape& shape, double h, const glm::vec3& uvw, float e) const;
    float erosionAt(const Vec3& x, const DetailFrame& frame) const;
    void chord(const Vec3& o, const Vec3& d, double t0, double t1, int i, std::vector<Chord>& out) const;
    int build(int first, int count);

    const NoiseVolume* noise_ = nullptr;
    Medium::Detail detail_{};
    double amp_ = 0, period_ = 1, noiseBound_ = 1;
    DetailFrame frame_;
    std::vector<Shape> shapes_;
    std::vector<Node> nodes_;
};

}  // namespace nephele
NEPHELE_API_END
