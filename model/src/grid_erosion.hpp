// The detail field (nephele/detail.hpp) as a cloud's radiance grid holds it, so that the light
// sees the eroded cloud the eye sees (issue 34 §2). A grid resolves no octave finer than two of
// its voxels: its octaves are drawn in full down to a wavelength of two voxels and fade out at
// one, the finer ones standing in with their mean, as for an eye far away (detailValue). The
// eye's finer octaves erode the skin within a voxel of what the grid holds.
//
// The detail is anchored to the air and the cloud need not move with it: a grid is made for
// the detail's offset from the cloud's first ellipsoid rounded to half a voxel (gridDetailStep),
// and made again only when the detail has slid that far through the cloud.
#pragma once

#include "nephele/cloud_radiance.hpp"
#include "nephele/detail.hpp"

#include <glm/gtc/type_precision.hpp>

#include <vector>

namespace nephele {

// A grid's voxels and box: radianceGridSize() voxels per side over radianceBox().
struct GridGeometry {
    int size = 0;
    Vec3 lo{0.0}, extent{1.0};  // m
    Vec3 cell() const { return extent / double(size); }
};
GridGeometry gridGeometry(const Scene& scene, const Cloud& cloud, const RadianceGridSettings& settings);

// The detail's offset from the cloud's first ellipsoid, in steps of half the grid's largest
// voxel side: what a grid of the eroded cloud depends on besides its shape. 0 with no detail.
glm::i64vec3 gridDetailOffset(const Scene& scene, const Cloud& cloud, const GridGeometry& g);

// The erosion delta = E D over a grid: read at the centres of the finer (sun) grid's voxels,
// kSunRefinement per voxel and axis, which are also the points voxelise() samples.
class GridErosion {
public:
    GridErosion(const Scene& scene, const Cloud& cloud, const GridGeometry& g);
    bool on() const { return on_; }
    // At a fine voxel centre (i, j, k) in [0, kSunRefinement size); evaluated where outside.
    float atFine(int i, int j, int k) const;
    // At a world point: trilinear between the fine voxel centres, clamped to the outermost ones.
    float at(const Vec3& x) const;

private:
    float evaluate(const Vec3& x) const;

    bool on_ = false;
    int n_ = 0;
    Vec3 lo_{0.0}, extent_{1.0}, cell_{1.0};  // the grid's box; its fine voxels' side
    Vec3 drift_{0.0};                         // the detail's drift the grid is made for (gridDetailOffset's rounding)
    model::DetailParams params_{};
    std::vector<float> delta_;
};

}  // namespace nephele
