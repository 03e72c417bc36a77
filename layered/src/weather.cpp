#include "nephele/weather.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace nephele {

CloudTypeLook cloudTypeLook(CigiCloudType type) {
    switch (type) {
        case CigiCloudType::Cumulonimbus: return {1.0, true};
        case CigiCloudType::Cumulus: return {0.9, true};
        case CigiCloudType::Stratocumulus: return {0.8, true};
        case CigiCloudType::Altocumulus: return {0.6, true};
        case CigiCloudType::Cirrocumulus: return {0.3, true};
        case CigiCloudType::Nimbostratus: return {1.0, false};
        case CigiCloudType::Stratus: return {0.8, false};
        case CigiCloudType::Altostratus: return {0.6, false};
        case CigiCloudType::Cirrostratus: return {0.25, false};
        case CigiCloudType::Cirrus: return {0.2, false};
        default: return {0.0, false};  // None (no cloud) and Other1..5 (unused: they keep the layer's)
    }
}

int cigiLayerId(int index) { return index < 3 ? index + 1 : index + 7; }

Weather Weather::of(const Scene& scene) {
    Weather w;
    w.sun = scene.sun;
    w.sky = scene.sky;
    for (int i = 0; i < int(scene.layers.size()); ++i) w.layers[cigiLayerId(i)] = {true, scene.layers[i]};
    return w;
}

void Weather::apply(const CloudLayerControl& c) {
    const std::string where = "CIGI weather control, layer " + std::to_string(c.layerId) + ": ";
    auto bad = [&](const std::string& what) { throw std::invalid_argument(where + what); };
    if (!((c.layerId >= 1 && c.layerId <= 3) || (c.layerId >= 10 && c.layerId <= 255)))
        bad("layer id must be 1..3 (cloud layers) or 10..255 (IG-defined cloud layers); 0 is ground fog and 4..9 "
            "precipitation, sand and dust, which Nephele does not draw");
    if (c.scope != CigiWeatherScope::Global) bad("scope must be global (Nephele's layers are not regional or entity weather)");
    if (int(c.cloudType) > 15) bad("cloud type must be 0..15, got " + std::to_string(int(c.cloudType)));
    if (!(c.coverage >= 0 && c.coverage <= 100)) bad("coverage must be 0..100 percent, got " + std::to_string(c.coverage));
    if (!std::isfinite(c.baseElevation)) bad("base elevation must be finite");
    if (!(c.thickness > 0 && std::isfinite(c.thickness))) bad("thickness must be > 0 m, got " + std::to_string(c.thickness));
    if (!(c.transitionBand >= 0 && std::isfinite(c.transitionBand))) bad("transition band must be >= 0 m");
    if (!(c.horizontalWindSpeed >= 0 && std::isfinite(c.horizontalWindSpeed)))
        bad("horizontal wind speed must be >= 0 m/s, got " + std::to_string(c.horizontalWindSpeed));
    if (!std::isfinite(c.verticalWindSpeed)) bad("vertical wind speed must be finite");
    if (!std::isfinite(c.windDirection)) bad("wind direction must be finite");

    auto [it, added] = layers.try_emplace(c.layerId);
    CloudLayer& l = it->second;
    if (added) l.layer.seed = unsigned(c.layerId);
    l.enabled = c.weatherEnable && c.cloudType != CigiCloudType::None;
    l.layer.coverage = c.coverage / 100;
    l.layer.base = c.baseElevation;
    l.layer.thickness = c.thickness;
    // From the direction it blows from, clockwise from north (+y): towards -(sin, cos).
    const double from = c.windDirection * 3.14159265358979323846 / 180;
    l.layer.wind = -c.horizontalWindSpeed * Vec2(std::sin(from), std::cos(from));
    if (c.cloudType >= CigiCloudType::Other1 || c.cloudType == CigiCloudType::None) return;
    const CloudTypeLook look = cloudTypeLook(c.cloudType);
    l.layer.density = look.density;
    l.layer.nearLod = look.nearLod;
}

void Weather::validate() const {
    const double sun = glm::length(this->sun.direction);
    if (!(std::isfinite(sun) && sun > 0.5 && sun < 2))
        throw std::invalid_argument("weather: the sun direction must be a unit vector (towards the sun)");
    for (const auto& entry : layers) {
        const auto id = entry.first;  // not a structured binding: clang 14 cannot capture one
        const Layer& y = entry.second.layer;
        auto bad = [&](const std::string& what) {
            throw std::invalid_argument("weather, layer " + std::to_string(id) + ": " + what);
        };
        if (!(y.thickness > 0 && std::isfinite(y.thickness))) bad("thickness must be > 0 m");
        if (!(y.extent > 0 && std::isfinite(y.extent))) bad("extent must be > 0 m");
        if (!(y.coverage >= 0 && y.coverage <= 1)) bad("coverage must be in [0, 1]");
        if (!(y.density >= 0 && y.density <= 1)) bad("density must be in [0, 1]");
        if (!(std::isfinite(y.base) && std::isfinite(y.wind.x) && std::isfinite(y.wind.y))) bad("base and wind must be finite");
    }
}

std::vector<Layer> Weather::enabledLayers() const {
    std::vector<Layer> out;
    for (const auto& [id, l] : layers)
        if (l.enabled) out.push_back(l.layer);
    return out;
}

}  // namespace nephele
