// The near LOD against the layer it stands for (hand_off.hpp).
#include "hand_off.hpp"

#include "nephele/camera.hpp"
#include "nephele/near_lod.hpp"
#include "nephele/sky.hpp"

#include "layer_assets.hpp"

#include <cmath>

namespace nephele {

bool meetsSlab(const Vec3& o, const Vec3& d, double base, double top, double from, double to) {
    double s0 = 0, s1 = 1e300;
    if (std::abs(d.z) > 1e-12) {
        double a = (base - o.z) / d.z, b = (top - o.z) / d.z;
        if (a > b) std::swap(a, b);
        s0 = std::max(s0, a), s1 = b;
    } else if (o.z < base || o.z > top) {
        return false;
    }
    const double h = std::hypot(d.x, d.y);
    if (h < 1e-12) return s1 > s0 && from <= 0;
    return std::min(s1, to / h) > std::max(s0, from / h);
}

Image drawOver(const Scene& scene, const View& view, const OpaquePass& opaque,
               const std::function<void(GLuint)>& draw) {
    FrameTarget target(view.camera.width, view.camera.height);
    opaque.draw(scene, view, target.framebuffer());
    draw(target.framebuffer());
    return target.readColor();
}

HandOff measureHandOff(const Scene& scene, const View& view, const LayeredSettings& layered, double bandFrom,
                       double reach, const EllipsoidSettings& compositorSettings) {
    const OpaquePass opaque;
    LayeredSettings nearSettings = layered;
    nearSettings.nearRadius = reach, nearSettings.blendBand = 0;
    NearLod nearLod(NearLodSettings{}, nearSettings);
    // One lighting volume and modulation texture for both, as SkyRenderer shares them.
    const auto assets = std::make_shared<LayerAssets>(layered);
    nearLod.shareAssets(assets);
    const std::vector<Cloud> near = nearLod.update(scene, view.eye, 0);
    EllipsoidRenderer compositor(compositorSettings);
    const Image nearOnly = drawOver(
        scene, view, opaque, [&](GLuint fb) { compositor.render(withNearClouds(scene, near), view, fb, false); });
    Scene cut = scene;
    cut.layers.front().extent = reach;
    LayeredSettings cutSettings = layered;
    cutSettings.extentFade = 0, cutSettings.nearRadius = 0, cutSettings.blendBand = 0;
    LayeredRenderer cutSky(cutSettings);
    cutSky.shareAssets(assets);
    const Image layerOnly = drawOver(cut, view, opaque, [&](GLuint fb) { cutSky.render(cut, view, fb, 0); });
    const Layer& l = scene.layers.front();
    const double top = l.base + l.thickness;
    double sums[5] = {0, 0, 0, 0, 0};  // near alpha, layer alpha, volume alpha; near, layer luminance in the band
    auto luminance = [](const Image& im, int x, int y) {
        return 0.2126 * im.at(x, y, 0) + 0.7152 * im.at(x, y, 1) + 0.0722 * im.at(x, y, 2);
    };
    HandOff out;
    for (int y = 0; y < nearOnly.height; ++y)
        for (int x = 0; x < nearOnly.width; ++x) {
            const Vec3 d = view.rayDirection(x + 0.5, y + 0.5);
            if (!meetsSlab(view.eye, d, l.base, top, 0, reach)) continue;
            ++out.reachPixels;
            sums[0] += nearOnly.at(x, y, 3), sums[1] += layerOnly.at(x, y, 3);
            const double tau =
                scene.medium.extinction * layerDensityIntegral(l, *cutSky.modulation(0), layered.modulation,
                                                               *cutSky.lighting(0), view.eye, d, reach, 0);
            sums[2] += 1 - std::exp(-tau);
            if (!meetsSlab(view.eye, d, l.base, top, bandFrom, reach)) continue;
            ++out.bandPixels;
            sums[3] += luminance(nearOnly, x, y), sums[4] += luminance(layerOnly, x, y);
        }
    const double n = std::max(out.reachPixels, 1), b = std::max(out.bandPixels, 1);
    out.nearOpacity = sums[0] / n, out.layerOpacity = sums[1] / n, out.volumeOpacity = sums[2] / n;
    out.nearRadiance = sums[3] / b, out.layerRadiance = sums[4] / b;
    return out;
}

}  // namespace nephele
