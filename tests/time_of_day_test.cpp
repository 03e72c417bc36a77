// The sun's position against published ephemeris values, the daylight model's colours, and the
// WGS84 geodetic / ECEF / east-north-up transforms (nephele/time_of_day.hpp, nephele/geodetic.hpp).
#include "nephele/geodetic.hpp"
#include "nephele/time_of_day.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

namespace nephele {
namespace {

// The angle between two azimuths, degrees in [0, 180].
double azimuthDifference(double a, double b) {
    const double d = std::fmod(std::fabs(a - b), 360.0);
    return d > 180 ? 360 - d : d;
}

// The published values are rounded or carry their own model's error; 0.1 degree is the
// accuracy the brief asks of a sun for lighting and ten times NOAA's stated 0.01.
constexpr double kTolDeg = 0.1;

// Reda & Andreas 2004, "Solar Position Algorithm for Solar Radiation Applications", NREL/TP-560-34302,
// Table A5.1 (the worked example): 2003-10-17 12:30:30 local standard time (UTC-7) at 39.742476 N,
// 105.1786 W, 1830.14 m: topocentric zenith 50.11162 degrees (with refraction, 820 mbar, 11 C),
// azimuth 194.34024 degrees. NOAA's refraction (standard atmosphere) differs from the paper's by
// 0.004 degree at this zenith and NOAA ignores the 0.002-degree parallax.
TEST(TimeOfDayTest, MatchesTheSpaPapersWorkedExample) {
    const SolarPosition p = solarPosition({2003, 10, 17, 19, 30, 30}, 39.742476, -105.1786);
    // measured: zenith 50.1086 (diff 0.003), azimuth 194.3426 (diff 0.002); broken (the equation
    // of time's sign flipped, tests/sabotage/70): zenith 49.165, azimuth 184.94 (diff 9.4).
    EXPECT_NEAR(p.apparentZenithDeg, 50.11162, kTolDeg);
    EXPECT_NEAR(p.azimuthDeg, 194.34024, kTolDeg);
    // The direction is the apparent elevation at that azimuth, x east, y north, z up.
    EXPECT_NEAR(glm::length(p.direction), 1.0, 1e-12);
    EXPECT_NEAR(p.direction.z, std::cos(glm::radians(50.11162)), 2e-3);
    EXPECT_LT(p.direction.y, 0);  // south of the observer ...
    EXPECT_LT(p.direction.x, 0);  // ... and a little west, in the afternoon
    EXPECT_GT(p.hourAngleDeg, 0);
}

// Meeus 1998, Astronomical Algorithms 2nd ed., Example 25.a: 1992 October 13.0 TD (JDE 2448908.5),
// apparent right ascension 198.38083, declination -7.78507 degrees (-7 47' 06"); Example 28.b: the
// equation of time that day is +13m 42.7s. (UT and TD differ by 59 s there: 0.0007 degree of sun.)
TEST(TimeOfDayTest, MatchesMeeusWorkedExamples) {
    const SolarPosition p = solarPosition({1992, 10, 13, 0, 0, 0}, 0, 0);
    EXPECT_DOUBLE_EQ(p.julianDay, 2448908.5);
    // measured: declination -7.78507, RA 198.38083 (diff below 0.000005), EoT 13m 42.65s (diff
    // 0.05 s); broken (the EoT's sign flipped): -13.71 min.
    EXPECT_NEAR(p.declinationDeg, -7.78507, kTolDeg);
    EXPECT_NEAR(p.rightAscensionDeg, 198.38083, kTolDeg);
    // 0.1 degree of hour angle is 0.4 minute of time.
    EXPECT_NEAR(p.equationOfTimeMin, 13 + 42.7 / 60, 0.4);
}

// The June solstice of 2023 is 2023-06-21 10:58 EDT = 14:58 UTC (US Naval Observatory, "Earth's
// Seasons", aa.usno.navy.mil/calculated/seasons?year=2023). At a solstice the sun's declination is
// the obliquity of the ecliptic, 23 26' 21.448" - 46.815" T (Meeus eq. 22.2, T in centuries from
// J2000) = 23.4362 degrees for T = 0.2347, nutation moving it by less than 0.003. At a pole the
// sun's geometric elevation is its declination at any hour: polar day in the north, polar night
// (the sun 23.4 degrees below the horizon) in the south.
TEST(TimeOfDayTest, PolarDayAndNightAtTheJuneSolstice) {
    const UtcTime solstice{2023, 6, 21, 14, 58, 0};
    const SolarPosition north = solarPosition(solstice, 90, 0);
    const SolarPosition south = solarPosition(solstice, -90, 0);
    // measured: +23.4384 and -23.4384 (diff 0.002).
    EXPECT_NEAR(north.elevationDeg, 23.4362, kTolDeg);
    EXPECT_NEAR(south.elevationDeg, -23.4362, kTolDeg);
    EXPECT_NEAR(glm::length(north.direction), 1.0, 1e-12);
    EXPECT_NEAR(glm::length(south.direction), 1.0, 1e-12);
    EXPECT_LT(south.direction.z, 0);
    const Daylight night = daylight(south);
    EXPECT_EQ(night.sun.intensity, 0.0);
    EXPECT_EQ(night.sky.zenith, Vec3(0.0));
    const Daylight day = daylight(solstice, 90, 0);  // from the time and place directly
    EXPECT_GT(day.sun.intensity, 0.0);
    EXPECT_EQ(day.sun.direction, north.direction);
}

// The highest geometric elevation of the sun over a UTC day and its azimuth there, scanned every
// 30 s (the elevation is flat at its top: 30 s costs less than 1e-4 degree).
struct Culmination {
    double elevationDeg = -90, azimuthDeg = 0;
};
Culmination culmination(int year, int month, int day, double latitudeDeg, double longitudeDeg) {
    Culmination c;
    for (int s = 0; s < 24 * 3600; s += 30) {
        const SolarPosition p =
            solarPosition({year, month, day, s / 3600, s / 60 % 60, double(s % 60)}, latitudeDeg, longitudeDeg);
        if (p.elevationDeg > c.elevationDeg) c = {p.elevationDeg, p.azimuthDeg};
    }
    return c;
}

// The December solstice of 2023 is 2023-12-22 03:27 UTC (USNO, as above: 21 Dec 22:27 EST); the
// declination is -23.4362 (as above) and moves by less than 0.001 degree in the day around it. At
// local noon the sun stands 90 - |latitude - declination| high, north of the observer when the
// declination is north of the latitude. Sydney Observatory (33.8597 S, 151.2046 E) has local noon
// at about 01:53 UTC on the 22nd: 79.576 degrees up, due north (southern summer). Tromso (69.6492 N,
// 18.9553 E) gets the polar night: the sun stays 3.085 degrees below the southern horizon at noon.
TEST(TimeOfDayTest, NoonAtTheDecemberSolsticeInBothHemispheres) {
    const Culmination sydney = culmination(2023, 12, 22, -33.8597, 151.2046);
    // measured: 79.5788 (diff 0.002), azimuth 0.1 from north.
    EXPECT_NEAR(sydney.elevationDeg, 90 - std::fabs(-33.8597 + 23.4362), kTolDeg);
    // The 30-s scan step moves the azimuth near the top by up to 0.6 degree.
    EXPECT_LT(azimuthDifference(sydney.azimuthDeg, 0), 1.0);

    const Culmination tromso = culmination(2023, 12, 22, 69.6492, 18.9553);
    // measured: -3.0874 (diff 0.002), azimuth 0.02 from south.
    EXPECT_NEAR(tromso.elevationDeg, 90 - (69.6492 + 23.4362), kTolDeg);
    EXPECT_LT(azimuthDifference(tromso.azimuthDeg, 180), 1.0);
    EXPECT_LT(tromso.elevationDeg, 0);  // below the horizon all day
}

TEST(TimeOfDayTest, RefractionIsNoaasAndLiftsTheSunAtTheHorizon) {
    // NOAA's polynomial at 0: 1735" = 0.482 degree; 58.1"/tan(45) - 0.07" + 0.000086" at 45.
    EXPECT_NEAR(atmosphericRefractionDeg(0), 1735.0 / 3600, 1e-12);
    EXPECT_NEAR(atmosphericRefractionDeg(45), (58.1 - 0.07 + 0.000086) / 3600, 1e-12);
    EXPECT_EQ(atmosphericRefractionDeg(89), 0.0);
    const SolarPosition p = solarPosition({2003, 10, 17, 19, 30, 30}, 39.742476, -105.1786);
    EXPECT_NEAR(p.apparentElevationDeg - p.elevationDeg, atmosphericRefractionDeg(p.elevationDeg), 1e-12);
}

TEST(TimeOfDayTest, RejectsInputOutOfRangeNamingTheField) {
    auto message = [](auto call) {
        try {
            call();
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("no exception");
    };
    EXPECT_NE(message([] { solarPosition({2023, 2, 29, 12, 0, 0}, 0, 0); }).find("time.day"), std::string::npos);
    EXPECT_NE(message([] { solarPosition({2023, 13, 1, 12, 0, 0}, 0, 0); }).find("time.month"), std::string::npos);
    EXPECT_NE(message([] { solarPosition({2023, 1, 1, 24, 0, 0}, 0, 0); }).find("time.hour"), std::string::npos);
    EXPECT_NE(message([] { solarPosition({2023, 1, 1, 0, 0, NAN}, 0, 0); }).find("time.second"), std::string::npos);
    EXPECT_NE(message([] { solarPosition({}, 91, 0); }).find("latitude"), std::string::npos);
    EXPECT_NE(message([] { solarPosition({}, 0, 181); }).find("longitude"), std::string::npos);
    EXPECT_NE(message([] { daylight(SolarPosition{}, ClearSky{.aerosolBeta = -1}); }).find("aerosolBeta"),
              std::string::npos);
    EXPECT_NE(message([] { geodeticToEcef({100, 0, 0}); }).find("latitude"), std::string::npos);
    EXPECT_NE(message([] { ecefToGeodetic(Vec3(0.0)); }).find("ecef"), std::string::npos);
    EXPECT_NO_THROW(solarPosition({2024, 2, 29, 23, 59, 60.5}, -90, -180));  // leap day, leap second
}

// A solar position with the given geometric elevation (the daylight model reads nothing else
// but the distance and the direction).
SolarPosition sunAt(double elevationDeg) {
    SolarPosition p;
    p.elevationDeg = elevationDeg;
    p.refractionDeg = atmosphericRefractionDeg(elevationDeg);
    p.apparentElevationDeg = std::min(elevationDeg + p.refractionDeg, 90.0);
    const double e = glm::radians(p.apparentElevationDeg);
    p.direction = Vec3(0, std::cos(e), std::sin(e));
    return p;
}

TEST(TimeOfDayTest, DaylightIsTheScenesDefaultWhiteSunUnderAZenithSun) {
    const Daylight d = daylight(sunAt(90));
    const Scene defaults;
    EXPECT_NEAR(d.sun.color.x, 1.0, 1e-12);
    EXPECT_NEAR(d.sun.color.y, 1.0, 1e-12);
    EXPECT_NEAR(d.sun.color.z, 1.0, 1e-12);
    EXPECT_NEAR(d.sun.intensity, defaults.sun.intensity, 1e-12);
    EXPECT_NEAR(glm::length(d.sky.zenith - defaults.sky.zenith), 0.0, 1e-12);
    EXPECT_NEAR(glm::length(d.sky.horizon - defaults.sky.horizon), 0.0, 1e-12);
    EXPECT_NEAR(glm::length(d.sky.ground - defaults.sky.ground), 0.0, 1e-12);
    EXPECT_NEAR(d.airMass, 1.0, 1e-3);
    // Clear-sky noon: measured 98.7 klx direct normal and 21.7 klx diffuse (measured clear skies
    // give 80-110 and 10-25).
    EXPECT_GT(d.sunIlluminanceLux, 80e3);
    EXPECT_LT(d.sunIlluminanceLux, 110e3);
    EXPECT_GT(d.skyIlluminanceLux, 10e3);
    EXPECT_LT(d.skyIlluminanceLux, 25e3);
}

TEST(TimeOfDayTest, TheSunReddensAndDimsMonotonicallyTowardsTheHorizon) {
    Daylight previous = daylight(sunAt(90));
    for (double h = 85; h >= 0; h -= 5) {
        const Daylight d = daylight(sunAt(h));
        SCOPED_TRACE(h);
        EXPECT_LT(d.sun.color.z / d.sun.color.x, previous.sun.color.z / previous.sun.color.x);
        EXPECT_LT(d.sun.color.y / d.sun.color.x, previous.sun.color.y / previous.sun.color.x);
        EXPECT_LT(d.sun.intensity * d.sun.color.y, previous.sun.intensity * previous.sun.color.y);
        EXPECT_LT(d.sunIlluminanceLux, previous.sunIlluminanceLux);
        EXPECT_LE(d.skyIlluminanceLux, previous.skyIlluminanceLux);
        previous = d;
    }
    // At the horizon the sun is red: measured colour (1, 0.018, 0.00002).
    const Daylight horizon = daylight(sunAt(0));
    EXPECT_DOUBLE_EQ(horizon.sun.color.x, 1.0);
    EXPECT_LT(horizon.sun.color.y, 0.4);
    EXPECT_LT(horizon.sun.color.z, 0.1);
    EXPECT_NEAR(kastenYoungAirMass(0), 37.92, 0.01);  // the formula of Kasten & Young 1989 at the horizon
}

TEST(TimeOfDayTest, TheSunSetsToZeroAndTheSkyFadesThroughTwilight) {
    // The disc's top sets at an apparent elevation of -0.27 degree (geometric about -0.85).
    EXPECT_GT(daylight(sunAt(-0.5)).sun.intensity, 0.0);
    EXPECT_EQ(daylight(sunAt(-0.9)).sun.intensity, 0.0);
    EXPECT_EQ(daylight(sunAt(-0.9)).sunIlluminanceLux, 0.0);
    EXPECT_EQ(daylight(sunAt(-30)).sun.intensity, 0.0);
    // The sky never jumps: each 0.05-degree step changes its brightness by under 6 %, and it
    // falls all the way from 10 degrees to the end of astronomical twilight.
    double previous = daylight(sunAt(10)).skyIlluminanceLux;
    for (double h = 9.95; h > -17.99; h -= 0.05) {
        const double lux = daylight(sunAt(h)).skyIlluminanceLux;
        ASSERT_LT(lux, previous) << h;
        ASSERT_GT(lux, previous * 0.94) << h;
        previous = lux;
    }
    const Daylight civilEnd = daylight(sunAt(-6));
    EXPECT_GT(civilEnd.skyIlluminanceLux, 1.0);  // measured 4.3 lux: about the 3.4 lux usually quoted
    EXPECT_LT(civilEnd.skyIlluminanceLux, 10.0);
    const Daylight night = daylight(sunAt(-18.5));
    EXPECT_EQ(night.sky.zenith, Vec3(0.0));
    EXPECT_EQ(night.sky.horizon, Vec3(0.0));
    EXPECT_EQ(night.sky.ground, Vec3(0.0));
    // At sunset the horizon glows warmer than the zenith: red over blue above blue's.
    const Daylight sunset = daylight(sunAt(0));
    EXPECT_GT(sunset.sky.horizon.x / sunset.sky.horizon.z, sunset.sky.zenith.x / sunset.sky.zenith.z);
}

// WGS84 (NIMA TR8350.2, table 3.1): a = 6378137 m, b = 6356752.3142 m.
TEST(GeodeticTest, KnownEcefPoints) {
    const Vec3 origin = geodeticToEcef({0, 0, 0});
    EXPECT_NEAR(origin.x, 6378137.0, 1e-6);
    EXPECT_NEAR(origin.y, 0.0, 1e-6);
    EXPECT_NEAR(origin.z, 0.0, 1e-6);
    const Vec3 east = geodeticToEcef({0, 90, 100});
    EXPECT_NEAR(east.x, 0.0, 1e-6);
    EXPECT_NEAR(east.y, 6378237.0, 1e-6);
    const Vec3 pole = geodeticToEcef({90, 37, 0});
    EXPECT_NEAR(std::hypot(pole.x, pole.y), 0.0, 1e-6);
    EXPECT_NEAR(pole.z, 6356752.3142, 1e-4);
    const Geodetic back = ecefToGeodetic({0, 0, -6356752.3142 - 50});
    EXPECT_NEAR(back.latitudeDeg, -90.0, 1e-12);
    EXPECT_NEAR(back.heightM, 50.0, 1e-4);
}

TEST(GeodeticTest, RoundTripsToAMillimetre) {
    std::mt19937 rng(35);
    std::uniform_real_distribution<double> lat(-90, 90), lon(-180, 180), height(-500, 40000);
    double worst = 0;
    for (int i = 0; i < 2000; ++i) {
        const Geodetic g{i < 4 ? 90.0 * (i % 2 ? 1 : -1) : lat(rng), lon(rng), i % 100 == 7 ? 2.0e6 : height(rng)};
        const Vec3 x = geodeticToEcef(g);
        const Geodetic h = ecefToGeodetic(x);
        // Compare points, not angles (the longitude at a pole is any).
        worst = std::max(worst, glm::length(geodeticToEcef(h) - x));
        const double latErrorM = glm::radians(std::fabs(h.latitudeDeg - g.latitudeDeg)) * kWgs84A;
        ASSERT_LT(latErrorM, 1e-3) << g.latitudeDeg << " " << g.longitudeDeg << " " << g.heightM;
        ASSERT_LT(std::fabs(h.heightM - g.heightM), 1e-3);
        const EnuFrame frame(g);
        const Vec3 enu{1234.5, -5678.25, 910.0};
        ASSERT_LT(glm::length(frame.ecefToEnu(frame.enuToEcef(enu)) - enu), 1e-3);
    }
    // measured: worst 4e-9 m; broken (one latitude iteration instead of eight): 22 m.
    EXPECT_LT(worst, 1e-3);
}

TEST(GeodeticTest, EnuAxesAtAPoint) {
    const EnuFrame zero({0, 0, 0});
    EXPECT_NEAR(glm::length(zero.east() - Vec3(0, 1, 0)), 0.0, 1e-15);
    EXPECT_NEAR(glm::length(zero.north() - Vec3(0, 0, 1)), 0.0, 1e-15);
    EXPECT_NEAR(glm::length(zero.up() - Vec3(1, 0, 0)), 0.0, 1e-15);

    // Toulouse, say: a right-handed orthonormal frame whose up is the ellipsoid's normal, and
    // whose north points to a point due north.
    const Geodetic origin{43.6045, 1.4440, 150};
    const EnuFrame frame(origin);
    EXPECT_NEAR(glm::length(glm::cross(frame.east(), frame.north()) - frame.up()), 0.0, 1e-15);
    EXPECT_NEAR(glm::dot(frame.east(), frame.north()), 0.0, 1e-15);
    const Vec3 ecef0 = geodeticToEcef(origin);
    EXPECT_NEAR(glm::length(frame.ecefToEnu(ecef0)), 0.0, 1e-6);
    // 100 m straight up along the normal.
    const Vec3 up = frame.geodeticToEnu({origin.latitudeDeg, origin.longitudeDeg, origin.heightM + 100});
    EXPECT_NEAR(glm::length(up - Vec3(0, 0, 100)), 0.0, 1e-6);
    // 0.01 degree north: the meridian's radius of curvature M = a(1-e2)/(1-e2 sin^2 lat)^1.5
    // times the angle, to the chord's 1e-6 m and the curvature drop below the plane.
    const double s = std::sin(glm::radians(origin.latitudeDeg + 0.005));
    const double m = kWgs84A * (1 - kWgs84E2) / std::pow(1 - kWgs84E2 * s * s, 1.5);
    const Vec3 north = frame.geodeticToEnu({origin.latitudeDeg + 0.01, origin.longitudeDeg, origin.heightM});
    EXPECT_NEAR(north.x, 0.0, 1e-6);
    EXPECT_NEAR(north.y, (m + origin.heightM) * glm::radians(0.01), 1e-3);
    EXPECT_LT(north.z, 0.0);  // the Earth curves away below the plane: about 0.1 m at 1.1 km
    // 0.01 degree east along the parallel, a circle of radius r = (N + h) cos(lat) about the axis:
    // x = r sin(dlon), and the chord falls r (1 - cos(dlon)) towards the axis, which is north by
    // sin(lat) and down by cos(lat) (measured 807.390, 0.0486, -0.0510 m).
    const double sl = std::sin(glm::radians(origin.latitudeDeg)), cl = std::cos(glm::radians(origin.latitudeDeg));
    const double r = (kWgs84A / std::sqrt(1 - kWgs84E2 * sl * sl) + origin.heightM) * cl;
    const double dl = glm::radians(0.01);
    const Vec3 eastward = frame.geodeticToEnu({origin.latitudeDeg, origin.longitudeDeg + 0.01, origin.heightM});
    EXPECT_NEAR(eastward.x, r * std::sin(dl), 1e-6);
    EXPECT_NEAR(eastward.y, r * (1 - std::cos(dl)) * sl, 1e-6);
    EXPECT_NEAR(eastward.z, -r * (1 - std::cos(dl)) * cl, 1e-6);

    // The sun's ENU direction goes to ECEF and back unchanged.
    const Vec3 sun = glm::normalize(Vec3(0.3, -0.5, 0.8));
    EXPECT_NEAR(glm::length(frame.ecefDirectionToEnu(frame.enuDirectionToEcef(sun)) - sun), 0.0, 1e-15);
}

}  // namespace
}  // namespace nephele
