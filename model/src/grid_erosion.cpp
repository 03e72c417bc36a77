// The detail field as a radiance grid holds it (grid_erosion.hpp).
#include "grid_erosion.hpp"

#include "grid_sampling.hpp"
#include "parallel.hpp"

#include <algorithm>
#include <cmath>

namespace nephele {

namespace {

double offsetStep(const GridGeometry& g) {
    const Vec3 c = g.cell();
    return 0.5 * std::max({c.x, c.y, c.z});
}

Vec3 anchorOf(const Cloud& cloud) { return cloud.ellipsoids.empty() ? Vec3(0.0) : cloud.ellipsoids.front().center; }

}  // namespace

GridGeometry gridGeometry(const Scene& scene, const Cloud& cloud, const RadianceGridSettings& settings) {
    GridGeometry g;
    g.size = radianceGridSize(scene, cloud, settings);
    Vec3 hi;
    radianceBox(cloud, g.lo, hi);
    g.extent = glm::max(hi - g.lo, Vec3(1.0));
    return g;
}

glm::i64vec3 gridDetailOffset(const Scene& scene, const Cloud& cloud, const GridGeometry& g) {
    if (!scene.medium.detail.on()) return glm::i64vec3(0);
    return glm::i64vec3(glm::round((anchorOf(cloud) - scene.medium.detail.drift) / offsetStep(g)));
}

GridErosion::GridErosion(const Scene& scene, const Cloud& cloud, const GridGeometry& g) {
    const Medium::Detail& detail = scene.medium.detail;
    on_ = detail.on() && scene.medium.extinction > 0;
    if (!on_) return;
    n_ = kSunRefinement * g.size;
    lo_ = g.lo;
    extent_ = g.extent;
    cell_ = g.extent / double(n_);
    drift_ = anchorOf(cloud) - Vec3(gridDetailOffset(scene, cloud, g)) * offsetStep(g);
    // The eye's octave count and normalisation (so the erosion keeps its distribution), drawn
    // down to two of the grid's voxels: detailOctaveCut's floor r = smallest / 2 is one voxel
    // where the point is its own eye (distance 0).
    params_ = detailParams(detail, Vec3(0.0));
    const Vec3 voxel = g.cell();
    params_.smallest = float(std::max(detail.smallest, 2 * std::max({voxel.x, voxel.y, voxel.z})));
    delta_.resize(std::size_t(n_) * n_ * n_);
    parallelFor(n_, [&](int k) {
        for (int j = 0; j < n_; ++j)
            for (int i = 0; i < n_; ++i)
                delta_[(std::size_t(k) * n_ + j) * n_ + i] = evaluate(lo_ + (Vec3(i, j, k) + 0.5) * cell_);
    });
}

float GridErosion::evaluate(const Vec3& x) const {
    model::DetailParams p = params_;
    p.origin = glm::vec3(x - drift_);
    return model::detailErosion(detailVolume(), p, glm::vec3(0.0f));
}

float GridErosion::atFine(int i, int j, int k) const {
    if (i < 0 || j < 0 || k < 0 || i >= n_ || j >= n_ || k >= n_) return evaluate(lo_ + (Vec3(i, j, k) + 0.5) * cell_);
    return delta_[(std::size_t(k) * n_ + j) * n_ + i];
}

float GridErosion::at(const Vec3& x) const {
    float value = 0.0f;
    trilinear(lo_, extent_, n_, x, [&](std::size_t i, float w) { value += w * delta_[i]; });
    return value;
}

}  // namespace nephele
