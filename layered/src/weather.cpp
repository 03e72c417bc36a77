#include "nephele/weather.hpp"

#include "weather_blend.hpp"

#include <algorithm>
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
    if (c.scope != CigiWeatherScope::Global)
        bad("scope must be global (Nephele's layers are not regional or entity weather)");
    if (int(c.cloudType) > 15) bad("cloud type must be 0..15, got " + std::to_string(int(c.cloudType)));
    if (!(c.coverage >= 0 && c.coverage <= 100))
        bad("coverage must be 0..100 percent, got " + std::to_string(c.coverage));
    if (!std::isfinite(c.baseElevation)) bad("base elevation must be finite");
    if (!(c.thickness > 0 && std::isfinite(c.thickness)))
        bad("thickness must be > 0 m, got " + std::to_string(c.thickness));
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
    if (!(transitionSeconds >= 0 && std::isfinite(transitionSeconds)))
        throw std::invalid_argument("weather: transitionSeconds must be a finite number >= 0 s, got " +
                                    std::to_string(transitionSeconds));
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
        if (!(std::isfinite(y.base) && std::isfinite(y.wind.x) && std::isfinite(y.wind.y)))
            bad("base and wind must be finite");
        if (!(y.lightingThickness >= 0 && std::isfinite(y.lightingThickness))) bad("lightingThickness must be >= 0 m");
    }
}

bool Weather::sameAs(const Weather& o) const {
    if (!(sun == o.sun && sky == o.sky && layers.size() == o.layers.size())) return false;
    for (auto a = layers.begin(), b = o.layers.begin(); a != layers.end(); ++a, ++b)
        if (!(a->first == b->first && a->second.enabled == b->second.enabled && a->second.layer == b->second.layer))
            return false;
    return true;
}

namespace {
// a + (b - a) s: exactly a where b == a, so that what a transition does not change stays
// bit-identical (the near LOD's cells and the clouds' radiance grids are keyed on exact values).
double lerp(double a, double b, double s) { return a + (b - a) * s; }
Vec2 lerp(const Vec2& a, const Vec2& b, double s) { return a + (b - a) * s; }
Vec3 lerp(const Vec3& a, const Vec3& b, double s) { return a + (b - a) * s; }

// Along the great circle from a to b (towards the sun), at a constant angular rate; b itself
// when they are equal.
Vec3 turn(const Vec3& from, const Vec3& to, double s) {
    if (from == to) return to;
    const Vec3 a = glm::normalize(from), b = glm::normalize(to);
    const double angle = std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0));
    if (angle < 1e-9) return glm::normalize(lerp(a, b, s));
    Vec3 axis = glm::cross(a, b);
    if (glm::length(axis) < 1e-9) {  // opposite: any great circle; the one through the zenith side
        axis = glm::cross(a, std::abs(a.z) < 0.9 ? Vec3(0, 0, 1) : Vec3(1, 0, 0));
    }
    axis = glm::normalize(axis);
    const double t = angle * s;
    return glm::normalize(a * std::cos(t) + glm::cross(axis, a) * std::sin(t) +
                          axis * glm::dot(axis, a) * (1 - std::cos(t)));
}

Layer lerpLayer(const Layer& a, const Layer& b, double s) {
    Layer l = b;  // the pattern's identity: seed, near LOD, city glow
    l.base = lerp(a.base, b.base, s);
    l.thickness = lerp(a.thickness, b.thickness, s);
    l.coverage = lerp(a.coverage, b.coverage, s);
    l.density = lerp(a.density, b.density, s);
    l.extent = lerp(a.extent, b.extent, s);
    l.wind = lerp(a.wind, b.wind, s);
    l.lightingThickness = b.lightingThickness > 0 ? b.lightingThickness : b.thickness;  // one volume: the target's
    return l;
}
}  // namespace

ShownWeather shownOf(const Weather& w) {
    ShownWeather out;
    out.sun = w.sun;
    out.sky = w.sky;
    for (const auto& [id, l] : w.layers)
        if (l.enabled) out.layers[id] = {l.layer, 1.0};
    return out;
}

ShownWeather blendShown(const ShownWeather& from, const Weather& to, double s) {
    if (!(s < 1)) return shownOf(to);
    s = std::max(s, 0.0);
    ShownWeather out;
    out.sun = to.sun;
    out.sun.direction = turn(from.sun.direction, to.sun.direction, s);
    out.sun.color = lerp(from.sun.color, to.sun.color, s);
    out.sun.intensity = lerp(from.sun.intensity, to.sun.intensity, s);
    out.sky.zenith = lerp(from.sky.zenith, to.sky.zenith, s);
    out.sky.horizon = lerp(from.sky.horizon, to.sky.horizon, s);
    out.sky.ground = lerp(from.sky.ground, to.sky.ground, s);
    for (const auto& [id, shown] : from.layers) {
        const auto target = to.layers.find(id);
        if (target != to.layers.end() && target->second.enabled) {
            out.layers[id] = {lerpLayer(shown.layer, target->second.layer, s), lerp(shown.fade, 1.0, s)};
        } else if (const double fade = shown.fade * (1 - s); fade > 0) {
            out.layers[id] = {shown.layer, fade};
        }
    }
    for (const auto& [id, l] : to.layers)
        if (l.enabled && !from.layers.count(id)) out.layers[id] = {l.layer, s};
    return out;
}

Layer farLayer(const ShownLayer& shown) {
    Layer l = shown.layer;
    if (shown.fade < 1) l.density *= shown.fade;
    return l;
}

Weather blendWeather(const Weather& from, const Weather& to, double s) {
    if (!(s < 1)) return to;
    const ShownWeather shown = blendShown(shownOf(from), to, s);
    Weather out;
    out.sun = shown.sun;
    out.sky = shown.sky;
    out.transitionSeconds = to.transitionSeconds;
    for (const auto& [id, l] : to.layers) out.layers[id] = {false, l.layer};  // disabled unless shown
    for (const auto& [id, l] : shown.layers) out.layers[id] = {true, farLayer(l)};
    return out;
}

std::vector<Layer> Weather::enabledLayers() const {
    std::vector<Layer> out;
    for (const auto& [id, l] : layers)
        if (l.enabled) out.push_back(l.layer);
    return out;
}

}  // namespace nephele
