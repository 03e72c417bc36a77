// The Gardner ellipsoid model, prepared on the CPU for one frame, and its exact CPU
// evaluation (`--method gardner-exact`), which the tiled GPU compositor approximates.
//
// The model (shaders/gardner_model.glsl, shared by GPU and CPU): each ellipsoid's opacity
// follows eq. (2) of Elinas & Stuerzlinger with T1, T2, D derived from the medium so that
// with medium.noise = 0 it is exactly 1 - exp(-tau) of the format's density field; its
// colour is the light its chord sends to the eye (shaders/cloud_light.glsl: the sun's single
// scattering, and the diffuse light of the sun and of the sky from the cloud's radiance grid,
// nephele/cloud_radiance.hpp), modulated by the same fBm noise. Ellipsoids are composited
// back to front by the distance of their centres from the eye.
#pragma once

#include "nephele/api.hpp"
#include "nephele/camera.hpp"
#include "nephele/cloud_radiance.hpp"
#include "nephele/gardner_model.hpp"
#include "nephele/image.hpp"
#include "nephele/noise.hpp"
#include "nephele/scene.hpp"

#include <cstdint>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

// `--method gardner-exact`: the model per pixel in float, exact ray-ellipsoid geometry and
// falloff, the light of every pixel's chord (no per-vertex light), no tiles and no 8-bit buffers, over the opaque
// background (objects inside clouds are covered only by the matter in front of them).
// RGBA: rgb linear radiance, a = cloud opacity.
// Order: PerEllipsoid composites whole ellipsoids back to front by centre distance, as the
// compositor's tiles must (so the two agree, order flips included); PerPixel sorts each
// pixel's contributions by the depth of their shading points, the order light actually
// meets them, which does not flip as the eye moves: the reference for order-flip popping.
// Weighted needs no order: the weighted, order-independent composite the GPU compositor can
// use instead of back to front (see compositeWeight in shaders/gardner_model.glsl): colour =
// the mean of the contributions' colours weighted by opacity times (tRef / tShade)^k,
// opacity = 1 - prod(1 - alpha), put "over" the background once; continuous in the eye's
// position, so it cannot pop. `weightExponent` is k (Weighted only).
// Moments is order-independent too (after Munstermann et al. 2018): the weighted mean with,
// as each contribution's weight, the transmittance in front of it reconstructed from the
// pixel's moments of absorbance over depth (momentTransmittance in gardner_model.glsl):
// nearly the per-pixel order, and continuous, so it cannot pop either.
// Opacity is the same in every order ("over" of opacities commutes); only colour differs.
enum class CompositeOrder { PerEllipsoid, PerPixel, Weighted, Moments };
// The clouds' radiance grids renderGardnerExact lights with, kept between its calls: a cloud's
// grid is made again only when its shape, its place, the sun's direction, the sky, the medium or
// the settings change (so the frames of a camera path over still clouds make them once).
class ExactLight {
public:
    // One grid per scene cloud, made with `settings` where the kept one does not fit.
    const std::vector<CloudRadiance>& grids(const Scene& scene, const RadianceGridSettings& settings);

private:
    struct Key {
        std::uint64_t light = 0;  // radianceGridKey
        Vec3 anchor{0.0};         // the cloud's first ellipsoid's centre (m): the grid's place
        bool operator==(const Key&) const = default;
    };
    std::vector<Key> keys_;
    std::vector<CloudRadiance> grids_;
};

// The clouds' radiance grids are computed with `light` (as the compositor's, so that the two
// agree), or taken from `kept` when given and still valid.
Image renderGardnerExact(const Scene& scene, const View& view, const NoiseVolume& noise,
                         const NoiseSettings& noiseSettings, CompositeOrder order = CompositeOrder::PerEllipsoid,
                         float weightExponent = model::kWeightExponent, const RadianceGridSettings& light = {},
                         ExactLight* kept = nullptr);

// The physics: per pixel 1 - exp(-sum of the ellipsoids' optical depths) along the ray
// (closed form per ellipsoid), up to the nearest opaque object. Grey image.
Image exactDensityOpacity(const Scene& scene, const View& view);

}  // namespace nephele
NEPHELE_API_END
