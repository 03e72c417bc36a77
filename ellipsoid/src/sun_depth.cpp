#include "sun_depth.hpp"

#include "nephele/gardner_model.hpp"
#include "nephele/projection.hpp"

#include <algorithm>
#include <cmath>

namespace nephele::detail {

SunDepthIndex::SunDepthIndex(const Cloud& cloud, const Vec3& sun) : sun_(sun) {
    // A plane across the sun: the shadow of each ellipsoid on it lies within a disc of its reach.
    u_ = glm::normalize(glm::cross(sun, std::abs(sun.z) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0)));
    v_ = glm::cross(sun, u_);
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY}, reachSum = 0;
    for (const Ellipsoid& e : cloud.ellipsoids) {
        const double reach = 1.01 * std::max({e.radii.x, e.radii.y, e.radii.z});
        entries_.push_back({ellipsoidToUnit(e), e.center, e.density, reach});
        const double p[2] = {glm::dot(e.center, u_), glm::dot(e.center, v_)};
        for (int k = 0; k < 2; ++k) lo[k] = std::min(lo[k], p[k] - reach), hi[k] = std::max(hi[k], p[k] + reach);
        reachSum += reach;
    }
    if (entries_.empty()) return;
    // Cells about an ellipsoid across, at most 256 x 256 of them.
    const double extent = std::max(hi[0] - lo[0], hi[1] - lo[1]);
    cell_ = std::max({2 * reachSum / double(entries_.size()), extent / 256, 1e-6 * extent, 1e-9});
    u0_ = lo[0], v0_ = lo[1];
    nu_ = std::clamp(int(std::ceil((hi[0] - lo[0]) / cell_)), 1, 256);
    nv_ = std::clamp(int(std::ceil((hi[1] - lo[1]) / cell_)), 1, 256);
    // Counting sort of (cell, entry) pairs: per cell, entries in the cloud's order.
    auto cells = [&](const Entry& e, auto&& visit) {
        const double pu = glm::dot(e.center, u_) - u0_, pv = glm::dot(e.center, v_) - v0_;
        const int i0 = std::clamp(int(std::floor((pu - e.reach) / cell_)), 0, nu_ - 1);
        const int i1 = std::clamp(int(std::floor((pu + e.reach) / cell_)), 0, nu_ - 1);
        const int j0 = std::clamp(int(std::floor((pv - e.reach) / cell_)), 0, nv_ - 1);
        const int j1 = std::clamp(int(std::floor((pv + e.reach) / cell_)), 0, nv_ - 1);
        for (int j = j0; j <= j1; ++j)
            for (int i = i0; i <= i1; ++i) visit(j * nu_ + i);
    };
    first_.assign(std::size_t(nu_) * nv_ + 1, 0);
    for (const Entry& e : entries_) cells(e, [&](int c) { ++first_[std::size_t(c) + 1]; });
    for (std::size_t c = 1; c < first_.size(); ++c) first_[c] += first_[c - 1];
    items_.resize(first_.back());
    std::vector<std::uint32_t> fill(first_.begin(), first_.end() - 1);
    for (std::uint32_t k = 0; k < entries_.size(); ++k) cells(entries_[k], [&](int c) { items_[fill[std::size_t(c)]++] = k; });
}

double SunDepthIndex::depth(const Vec3& from) const {
    if (entries_.empty()) return 0;
    const double pu = glm::dot(from, u_) - u0_, pv = glm::dot(from, v_) - v0_;
    const int i = int(std::floor(pu / cell_)), j = int(std::floor(pv / cell_));
    if (i < 0 || j < 0 || i >= nu_ || j >= nv_) return 0;  // beyond every shadow
    double sum = 0;
    const std::size_t c = std::size_t(j) * nu_ + i;
    for (std::uint32_t k = first_[c]; k < first_[c + 1]; ++k) {
        const Entry& e = entries_[items_[k]];
        const Vec3 offset = from - e.center;
        const Vec3 across = offset - glm::dot(offset, sun_) * sun_;
        if (glm::dot(across, across) > e.reach * e.reach) continue;  // its term would be exactly 0
        const glm::vec3 o(e.unit * offset), d(e.unit * sun_);
        sum += e.density * model::segmentDepth(o, d, 0.0f, 1e30f);
    }
    return sum;
}

}  // namespace nephele::detail
