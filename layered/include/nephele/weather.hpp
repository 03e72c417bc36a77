// The weather a host changes while the aircraft flies, shaped after CIGI 3.3: the cloud fields
// of the Weather Control packet (ICD section 4.1.12, packet 12) per cloud layer, plus the sun
// and the sky. SkyRenderer::update() takes a Weather every frame and applies what changed
// without a stall (see nephele/sky.hpp and the CIGI table of docs/embedding.md).
#pragma once

#include "nephele/api.hpp"
#include "nephele/scene.hpp"

#include <cstdint>
#include <map>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele {

// CIGI 3.3 Weather Control, Cloud Type.
enum class CigiCloudType : std::uint8_t {
    None = 0,
    Altocumulus = 1,
    Altostratus = 2,
    Cirrocumulus = 3,
    Cirrostratus = 4,
    Cirrus = 5,
    Cumulonimbus = 6,
    Cumulus = 7,
    Nimbostratus = 8,
    Stratocumulus = 9,
    Stratus = 10,
    Other1 = 11,
    Other2 = 12,
    Other3 = 13,
    Other4 = 14,
    Other5 = 15
};
// CIGI 3.3 Weather Control, Scope.
enum class CigiWeatherScope : std::uint8_t { Global = 0, Regional = 1, Entity = 2 };

// The fields of a CIGI 3.3 Weather Control packet that apply to a cloud layer, in the ICD's
// units. Humidity, air temperature, visibility, scud, random winds and lightning, severity,
// barometric pressure and aerosol concentration do not apply to Nephele's clouds and are left
// out (docs/embedding.md's table says what each field becomes).
struct CloudLayerControl {
    int layerId = 1;            // 1..3: CIGI's cloud layers 1..3; 10..255: IG-defined, taken as further cloud layers
    bool weatherEnable = true;  // false: the layer is not drawn (Nephele keeps its state for a later enable)
    CigiWeatherScope scope = CigiWeatherScope::Global;  // Global only: Nephele's layers cover the world
    CigiCloudType cloudType = CigiCloudType::Cumulus;   // sets the layer's density and near LOD (cloudTypeLook)
    double coverage = 60;                               // percent, 0..100
    double baseElevation = 1500;                        // m, the layer's base (Nephele's z)
    double thickness = 600;                             // m, > 0
    double transitionBand = 0;  // m, >= 0 (not rendered: the layer's density already fades to 0 at its base and top)
    double horizontalWindSpeed = 0;  // m/s, >= 0
    double verticalWindSpeed = 0;    // m/s (not rendered: the layers stay at their base)
    double windDirection = 0;        // degrees clockwise from true north (+y), the direction the wind blows FROM
};

// How a cloud type looks: the layer's density and whether its near clouds become ellipsoid
// cumulus (puffy types) or the layer is drawn all the way in (sheet types). Other1..5 keep
// the layer's own values.
struct CloudTypeLook {
    double density = 1;
    bool nearLod = true;
};
CloudTypeLook cloudTypeLook(CigiCloudType type);

// The CIGI layer id of the scene's layer `index` (0, 1, 2 -> 1, 2, 3; 3, 4, ... -> 10, 11, ...).
int cigiLayerId(int index);

struct Weather {
    struct CloudLayer {
        bool enabled = true;
        Layer layer;  // windOffset is SkyRenderer's (it integrates the drift): ignored here
    };
    Sun sun;
    Sky sky;
    std::map<int, CloudLayer> layers;  // by CIGI layer id; drawn in this order when enabled
    // The time (s, >= 0) SkyRenderer::update takes to go from what it shows to this weather when
    // it differs from the last one given (a change of transitionSeconds alone is no change):
    // 0 applies it in the frame it is given. See blendWeather and docs/embedding.md, "Transitions".
    double transitionSeconds = 0;

    // The scene's sun, sky and layers (ids cigiLayerId(0), cigiLayerId(1), ...).
    static Weather of(const Scene& scene);
    // Applies a packet to its layer (made with Layer's defaults and seed = layer id when new).
    // Throws std::invalid_argument naming the layer and the field for a value out of range, a
    // layer id that is no cloud layer (0 ground fog, 4..9 precipitation, sand, dust) or a
    // regional or entity scope.
    void apply(const CloudLayerControl& control);
    // The enabled layers in id order: the scene's `layers`.
    std::vector<Layer> enabledLayers() const;
    // Throws std::invalid_argument naming the layer id and the field for what a scene file
    // could not hold (thickness or extent <= 0, coverage or density outside [0, 1], a non-finite
    // base or wind), a sun direction that is not a direction or a transitionSeconds that is
    // negative or not finite. SkyRenderer::update calls it.
    void validate() const;
    // The same sun, sky and layers (transitionSeconds aside): what makes update() start a transition.
    bool sameAs(const Weather& other) const;
};

// The weather a transition shows at s in [0, 1] of its way from `from` to `to` (s >= 1: `to`
// itself). Continuous quantities move linearly: each layer's coverage, density, base,
// thickness, extent and wind vector, the sun's intensity and colour and the sky's colours; the
// sun's direction turns along the great circle at a constant rate. The rest is the pattern's
// identity and takes `to`'s at once: a layer's seed, near LOD flag and city glow. A layer
// enabled in `to` only fades in (`to`'s layer, density x s); one enabled in `from` only fades
// out (`from`'s, density x (1 - s)), disabled at s = 1. While s < 1 a layer present in `to` is
// lit for `to`'s thickness (Layer::lightingThickness): one lighting volume per change.
Weather blendWeather(const Weather& from, const Weather& to, double s);

}  // namespace nephele
NEPHELE_API_END
