// The sun for a date, a time and a place: where it is (the NOAA solar position algorithm) and
// how it lights a scene (its colour and illuminance after the clear atmosphere, the sky's
// ambient colour), in the units of the scene's `sun` and `sky` (data/scene-format.md).
// Formulas, sources, accuracy and units: docs/embedding.md, "Time of day and geodetic frame".
//
// Directions are in the local east-north-up frame of the observer: x east, y north, z up,
// Nephele's world frame. Angles in degrees. Functions throw std::invalid_argument naming the
// field for input out of range; nothing here prints or touches GL.
#pragma once

#include "nephele/api.hpp"
#include "nephele/scene.hpp"

NEPHELE_API_BEGIN
namespace nephele {

// A UTC instant on the Gregorian calendar. No time zones and no daylight saving: a host
// converts its local clock first (UTC = local standard time - zone offset).
struct UtcTime {
    int year = 2000;    // 1583..4000 (accuracy: see solarPosition)
    int month = 1;      // 1..12
    int day = 1;        // 1..days in that month
    int hour = 12;      // 0..23
    int minute = 0;     // 0..59
    double second = 0;  // [0, 61) (a leap second's 60.x is accepted)
};

// The Julian Day of `time` (days since -4712-01-01 12:00 UT), Meeus 1998 eq. (7.1).
// Throws std::invalid_argument naming the field of `time` that is out of range.
double julianDay(const UtcTime& time);

struct SolarPosition {
    double julianDay = 0;             // of the instant (UT, the NOAA algorithm ignores Delta T)
    double declinationDeg = 0;        // apparent geocentric declination
    double rightAscensionDeg = 0;     // apparent geocentric right ascension, [0, 360)
    double equationOfTimeMin = 0;     // apparent minus mean solar time, minutes
    double distanceAu = 1;            // Earth-sun distance, astronomical units
    double hourAngleDeg = 0;          // local hour angle, (-180, 180], > 0 in the afternoon
    double elevationDeg = 0;          // geometric (true) elevation, no refraction, [-90, 90]
    double refractionDeg = 0;         // NOAA's standard-atmosphere refraction at elevationDeg
    double apparentElevationDeg = 0;  // elevationDeg + refractionDeg: where the eye sees it
    double apparentZenithDeg = 90;    // 90 - apparentElevationDeg
    double azimuthDeg = 0;            // clockwise from true north, [0, 360)
    Vec3 direction{0, 0, 1};          // unit, towards the apparent sun, east-north-up
};

// Where the sun is at `time` for an observer at geodetic `latitudeDeg` (-90..90, north > 0)
// and `longitudeDeg` (-180..180, east > 0). The NOAA Solar Calculator's equations (after
// Meeus 1998): about 0.01 degree for 1800..2100, worse outside (the series are for
// the years around 2000). The direction uses the apparent (refracted) elevation and the
// azimuth. Throws std::invalid_argument naming the field out of range.
SolarPosition solarPosition(const UtcTime& time, double latitudeDeg, double longitudeDeg);

// NOAA's atmospheric refraction (degrees, to add) at geometric elevation `elevationDeg`:
// Saemundsson-like terms above 5 degrees, a polynomial from -0.575 to 5, -20.772"/tan(e)
// below, 0 above 85. About 0.57 degree at the horizon.
double atmosphericRefractionDeg(double elevationDeg);

// The clear atmosphere the daylight model uses.
struct ClearSky {
    double aerosolBeta = 0.1;         // Angstrom turbidity: aerosol optical depth at 1 um, >= 0
    double aerosolAlpha = 1.3;        // Angstrom exponent, >= 0
    double pressureRatio = 1.0;       // surface pressure / 1013.25 hPa (scales Rayleigh), > 0
    double zenithSunIntensity = 3.0;  // the scene `sun.intensity` given to the sun at the zenith
                                      // (3.0: the scene format's default daylight), > 0
    Sky zenithSunSky;                 // the scene `sky` for a sun at the zenith (the format's default)
};

// The sun and ambient a host lights with, for a solar position.
struct Daylight {
    // Ready for Scene::sun or Weather::sun: direction = the apparent direction; color has its
    // largest channel 1 and is white for the sun at the zenith; color*intensity per channel is
    // zenithSunIntensity * T(channel)/T_zenith(channel) (T: direct transmittance) times the
    // visible fraction of the disc, so it reddens and dims towards the horizon and is 0 once
    // the disc has set (apparent elevation below -0.27 degree, geometric about -0.83).
    Sun sun;
    // Ready for Scene::sky or Weather::sky: zenithSunSky scaled by the clear sky's diffuse
    // horizontal illuminance relative to a zenith sun (ground: by all light reaching it), the
    // horizon tinted towards the sun's colour at low sun; it fades smoothly through civil and
    // nautical twilight and is 0 below -18 degrees (astronomical night).
    Sky sky;
    double sunIlluminanceLux = 0;  // direct normal illuminance of the sun at the surface, lux
    double skyIlluminanceLux = 0;  // diffuse horizontal illuminance of the clear sky, lux
    Vec3 transmittance{0.0};       // direct transmittance at 680, 550, 440 nm (R, G, B)
    double airMass = 0;            // Kasten-Young relative air mass (0 when the sun is down)
};

// The daylight of `position` under `sky`. Throws std::invalid_argument naming the field of
// `sky` out of range.
Daylight daylight(const SolarPosition& position, const ClearSky& sky = {});
// The same for a UTC time and a place: `scene.sun = daylight(time, lat, lon).sun`.
Daylight daylight(const UtcTime& time, double latitudeDeg, double longitudeDeg, const ClearSky& sky = {});

// Relative optical air mass at geometric elevation `elevationDeg` (Kasten & Young 1989):
// 1 at the zenith, about 38 at the horizon; held at its value for -0.9 degree below that.
double kastenYoungAirMass(double elevationDeg);

}  // namespace nephele
NEPHELE_API_END
