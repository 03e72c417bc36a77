// WGS84 geodetic coordinates, Earth-centred Earth-fixed (ECEF) coordinates and a local
// east-north-up (ENU) frame at a geodetic origin, in double precision. The ENU frame is
// Nephele's world frame (x east, y north, z up, metres) when the scene's origin is put at the
// frame's origin. Formulas: docs/embedding.md, "Time of day and geodetic frame".
#pragma once

#include "nephele/api.hpp"
#include "nephele/scene.hpp"

NEPHELE_API_BEGIN
namespace nephele {

// WGS84 (NIMA TR8350.2): semi-major axis a and flattening f; e2 = f(2 - f).
inline constexpr double kWgs84A = 6378137.0;
inline constexpr double kWgs84F = 1.0 / 298.257223563;
inline constexpr double kWgs84E2 = kWgs84F * (2.0 - kWgs84F);

struct Geodetic {
    double latitudeDeg = 0;   // -90..90, north > 0
    double longitudeDeg = 0;  // east > 0 (any finite value; ecefToGeodetic returns (-180, 180])
    double heightM = 0;       // above the ellipsoid, metres
};

// ECEF metres (x towards lat 0 lon 0, z towards the north pole). Throws std::invalid_argument
// naming the field for a latitude outside [-90, 90] or a value that is not finite.
Vec3 geodeticToEcef(const Geodetic& point);
// The inverse, by fixed-point iteration on the latitude (converges to below 1e-12 rad for
// heights from -100 km to 10,000 km; at the poles the longitude is 0). Throws
// std::invalid_argument for a non-finite coordinate or a point within 100 km of the centre.
Geodetic ecefToGeodetic(const Vec3& ecef);

// The east-north-up frame tangent to the ellipsoid at `origin`: enu = R (ecef - ecef0), with R's
// rows the unit vectors east, north, up expressed in ECEF.
class EnuFrame {
public:
    explicit EnuFrame(const Geodetic& origin);  // throws like geodeticToEcef

    const Geodetic& origin() const { return origin_; }
    const Vec3& originEcef() const { return originEcef_; }
    const Vec3& east() const { return east_; }    // unit, ECEF
    const Vec3& north() const { return north_; }  // unit, ECEF
    const Vec3& up() const { return up_; }        // unit, ECEF: the ellipsoid's normal

    Vec3 ecefToEnu(const Vec3& ecef) const;
    Vec3 enuToEcef(const Vec3& enu) const;
    Vec3 geodeticToEnu(const Geodetic& point) const { return ecefToEnu(geodeticToEcef(point)); }
    Geodetic enuToGeodetic(const Vec3& enu) const { return ecefToGeodetic(enuToEcef(enu)); }
    // A direction (no translation) between the frames.
    Vec3 ecefDirectionToEnu(const Vec3& d) const { return {glm::dot(east_, d), glm::dot(north_, d), glm::dot(up_, d)}; }
    Vec3 enuDirectionToEcef(const Vec3& d) const { return east_ * d.x + north_ * d.y + up_ * d.z; }

private:
    Geodetic origin_;
    Vec3 originEcef_, east_, north_, up_;
};

}  // namespace nephele
NEPHELE_API_END
