// Celestial Sphere Control to the scene's sun and sky, Entity Control to an eye in the scene's
// frame (nephele/cigi_scene.hpp).
#include "nephele/cigi_scene.hpp"

#include "nephele/generate.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace nephele::cigi {

std::optional<UtcTime> celestialTime(const CelestialSphereControl& p) {
    if (!p.dateTimeValid) return std::nullopt;
    UtcTime t;
    t.month = int(p.date / 1000000);
    t.day = int(p.date / 10000 % 100);
    t.year = int(p.date % 10000);
    t.hour = p.hour;
    t.minute = p.minute;
    t.second = 0;
    const std::string where = "Celestial Sphere Control: ";
    if (t.month < 1 || t.month > 12)
        throw std::invalid_argument(where + "the Date's month (MMDDYYYY) must be 1..12, got " + std::to_string(p.date));
    try {
        julianDay(t);  // checks the day of that month, the hour, the minute and the year
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(where + e.what());
    }
    return t;
}

CelestialLight applyCelestial(const CelestialSphereControl& p, double latitudeDeg, double longitudeDeg,
                              CelestialLight& day) {
    if (const std::optional<UtcTime> t = celestialTime(p)) {
        const Daylight d = daylight(*t, latitudeDeg, longitudeDeg);
        day = {d.sun, d.sky};
    }
    CelestialLight light = day;
    if (!p.sunEnable) light.sun.intensity = 0;
    return light;
}

EntityPose entityPose(const EntityControl& p, const EnuFrame& frame) {
    if (!(std::isfinite(p.yaw) && std::isfinite(p.pitch) && std::isfinite(p.roll)))
        throw std::invalid_argument("Entity Control " + std::to_string(p.entityId) +
                                    ": roll, pitch and yaw must be finite");
    const Geodetic where{p.latitude, p.longitude, p.altitude};
    const EnuFrame local(where);  // throws for a latitude out of range or a value not finite
    const double y = glm::radians(double(p.yaw)), q = glm::radians(double(p.pitch)), r = glm::radians(double(p.roll));
    // In the entity's east-north-up frame: the nose at heading y and elevation q; its right wing
    // level; the top turned about the nose towards the right wing by the roll.
    const Vec3 forward(std::sin(y) * std::cos(q), std::cos(y) * std::cos(q), std::sin(q));
    const Vec3 right(std::cos(y), -std::sin(y), 0);
    const Vec3 top = glm::cross(right, forward);
    const Vec3 up = std::cos(r) * top + std::sin(r) * right;
    EntityPose pose;
    pose.position = frame.geodeticToEnu(where);
    pose.forward = glm::normalize(frame.ecefDirectionToEnu(local.enuDirectionToEcef(forward)));
    pose.up = glm::normalize(frame.ecefDirectionToEnu(local.enuDirectionToEcef(up)));
    return pose;
}

Object entityBox(const EntityPose& pose) {
    Object box;
    box.type = Object::Type::Box;
    box.center = pose.position;
    box.size = Vec3(12, 10, 3);  // span (local x), length (local y), height (local z)
    const Vec3 right = glm::normalize(glm::cross(pose.forward, pose.up));
    box.rotationDeg = degreesFromRotation(glm::dmat3(right, pose.forward, pose.up));
    box.color = Vec3(0.5);
    return box;
}

}  // namespace nephele::cigi
