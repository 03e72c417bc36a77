#include "frame_change.hpp"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace nephele {

namespace {
constexpr double kAll = std::numeric_limits<double>::infinity();

// The largest change of an entry (infinite when the sizes differ, or one is NaN).
double largestStep(const std::vector<double>& a, const std::vector<double>& b) {
    if (a.size() != b.size()) return kAll;
    double step = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        const double d = std::abs(a[i] - b[i]);
        if (std::isnan(d)) return kAll;
        step = std::max(step, d);
    }
    return step;
}

void compareLayer(const LayerRecord& now, const LayerRecord& last, double maxStep, FrameChange& c) {
    c.step = std::max(c.step, largestStep(now.weather, last.weather));
    if (now.textures == last.textures) return;
    const double density = std::max(now.density, last.density);
    if (density <= maxStep) c.step = std::max(c.step, density);
    else if (now.textures.light && last.textures.light && now.textures.modulation && last.textures.modulation)
        c.texturesReplaced = true;
    else c.step = kAll;
}
}  // namespace

FrameRecord frameRecord(const Scene& scene, const std::vector<LayerTextures>& textures) {
    FrameRecord r;
    // A size's logarithm: its steps are relative changes (0.01: 1%).
    auto logarithm = [](double size) { return std::log(std::max(size, 1e-9)); };
    for (std::size_t i = 0; i < scene.layers.size(); ++i) {
        const Layer& l = scene.layers[i];
        LayerRecord& e = r.layers.emplace_back();
        e.weather = {l.coverage, l.density, double(l.seed), l.nearLod ? 1.0 : 0.0};
        // The base as a size too above 100 m (a move of 1% of it is 0.01: the eye is about that far
        // from what it sees of the layer), linear below (1 m is 0.01), whatever the thickness does.
        e.weather.push_back(std::asinh(l.base / 100.0));
        e.weather.insert(e.weather.end(), {logarithm(l.thickness), logarithm(l.extent)});
        e.weather.push_back(l.cityGlow ? glm::length(l.cityGlow->color * l.cityGlow->strength) : 0.0);
        e.textures = i < textures.size() ? textures[i] : LayerTextures{};
        e.density = l.density;
    }
    r.weather = {scene.sun.direction.x, scene.sun.direction.y, scene.sun.direction.z};
    r.weather.push_back(logarithm(glm::length(scene.sun.color * scene.sun.intensity)));
    r.weather.insert(r.weather.end(), {scene.medium.extinction * 100, scene.medium.albedo * 100, scene.medium.hgG});
    return r;
}

FrameChange compareFrames(const FrameRecord& now, const FrameRecord& last, double maxStep) {
    const std::size_t n = now.layers.size(), m = last.layers.size();
    // The layers matched in order, but for `skip`, an index of the longer list left unmatched.
    auto matched = [&](std::size_t skip) {
        FrameChange c;
        c.step = largestStep(now.weather, last.weather);
        const bool fewer = n < m;
        for (std::size_t i = 0, j = 0; i < n || j < m;) {
            if (n != m && (fewer ? j : i) == skip) {
                c.step = std::max(c.step, (fewer ? last.layers[j++] : now.layers[i++]).density);
                continue;
            }
            if (i >= n || j >= m) return FrameChange{kAll, false};
            compareLayer(now.layers[i++], last.layers[j++], maxStep, c);
        }
        return c;
    };
    if (n == m) return matched(n);
    if (std::max(n, m) - std::min(n, m) != 1) return {kAll, false};
    FrameChange best{kAll, false};
    for (std::size_t k = 0; k < std::max(n, m); ++k) {
        const FrameChange c = matched(k);
        if (c.step < best.step || (c.step == best.step && best.texturesReplaced && !c.texturesReplaced)) best = c;
    }
    return best;
}

}  // namespace nephele
