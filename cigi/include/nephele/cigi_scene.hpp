// What `nephele ig` makes of the host's Celestial Sphere Control and Entity Control packets in the
// scene's frame: the sun and sky of a date and time at the --origin, and an entity's eye (position
// and attitude) in the scene's east-north-up frame. No GL and no sockets, so that the unit tests
// check them from packet to scene (docs/cigi.md, "What is done with each packet").
#pragma once

#include "nephele/cigi.hpp"
#include "nephele/geodetic.hpp"
#include "nephele/scene.hpp"
#include "nephele/time_of_day.hpp"

#include <optional>

NEPHELE_API_BEGIN
namespace nephele::cigi {

// The UTC instant of a Celestial Sphere Control: its Date (MMDDYYYY as a decimal number) at its
// Hour:Minute, or nullopt when its Date/Time Valid bit is clear. Throws std::invalid_argument
// naming the field out of range (a month 13, a day 31 of June, an hour 24, a year before 1583).
std::optional<UtcTime> celestialTime(const CelestialSphereControl& packet);

// The light `nephele ig` draws with: the scene's sun and sky.
struct CelestialLight {
    Sun sun;
    Sky sky;
};

// The light after `packet`. `day` is the light with the sun enabled: the scene's, then that of
// the last valid date and time. With Date/Time Valid set, `day` becomes the daylight
// (nephele::daylight) of the packet's instant at the geodetic latitudeDeg, longitudeDeg. The
// light returned is `day`'s, its sun's intensity 0 when Sun Enable is clear (no sunlight; the
// sky's light stays). Throws as celestialTime and solarPosition do; `day` is then unchanged.
CelestialLight applyCelestial(const CelestialSphereControl& packet, double latitudeDeg, double longitudeDeg,
                              CelestialLight& day);

// An entity as an eye: where it is and where it looks, in the scene's frame (metres, x east,
// y north, z up at the frame's origin).
struct EntityPose {
    Vec3 position{0.0};
    Vec3 forward{0, 1, 0};  // unit: the entity's nose
    Vec3 up{0, 0, 1};       // unit, orthogonal to forward: the entity's top
};

// The pose of an Entity Control with geodetic coordinates (not attached to a parent): its
// latitude, longitude and altitude (taken as the height above the WGS84 ellipsoid) through
// `frame`, and its attitude: yaw clockwise from true north, pitch nose up, roll right wing
// down (degrees), in the entity's own local level frame, turned into the scene's axes. Throws
// std::invalid_argument for a latitude outside [-90, 90] or a value that is not finite.
EntityPose entityPose(const EntityControl& packet, const EnuFrame& frame);

// What `nephele ig` draws for an entity other than the eye: a grey box the size of a light
// aircraft (12 m span along its right wing, 10 m nose to tail, 3 m high) centred on the pose,
// turned to its attitude. Entity types are not modelled.
Object entityBox(const EntityPose& pose);

}  // namespace nephele::cigi
NEPHELE_API_END
