// The NOAA solar position algorithm, and a clear-sky daylight model for the scene's sun and sky.
// Sources and accuracy: docs/embedding.md, "Time of day and geodetic frame".
#include "nephele/time_of_day.hpp"

#include <glm/trigonometric.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace nephele {
namespace {

double wrap360(double a) {
    a = std::fmod(a, 360.0);
    return a < 0 ? a + 360.0 : a;
}

void require(bool ok, const std::string& field, const std::string& rule, double value) {
    if (!ok) throw std::invalid_argument(field + ": must be " + rule + ", got " + std::to_string(value));
}

bool leapYear(int y) { return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0; }
int daysInMonth(int y, int m) {
    static constexpr int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
    return m == 2 && leapYear(y) ? 29 : kDays[m - 1];
}

void validate(const UtcTime& t) {
    require(t.year >= 1583 && t.year <= 4000, "time.year", "in 1583..4000 (Gregorian)", t.year);
    require(t.month >= 1 && t.month <= 12, "time.month", "in 1..12", t.month);
    require(t.day >= 1 && t.day <= daysInMonth(t.year, t.month), "time.day",
            "in 1.." + std::to_string(daysInMonth(t.year, t.month)) + " for that month", t.day);
    require(t.hour >= 0 && t.hour <= 23, "time.hour", "in 0..23", t.hour);
    require(t.minute >= 0 && t.minute <= 59, "time.minute", "in 0..59", t.minute);
    require(std::isfinite(t.second) && t.second >= 0 && t.second < 61, "time.second", "in [0, 61)", t.second);
}

// Wavelengths (um) the three channels stand for, and their Rec. 709 luminance weights.
constexpr double kLambda[3] = {0.680, 0.550, 0.440};
constexpr double kLuma[3] = {0.2126, 0.7152, 0.0722};
// Luminous solar constant (lux at 1 au): Darula, Kittler & Gueymard 2005, Solar Energy 79(5).
constexpr double kLuminousSolarConstant = 133800.0;
// The sun's angular radius (degrees) at 1 au.
constexpr double kSunRadiusDeg = 0.2666;

// Rayleigh optical depth of the standard atmosphere at `lambdaUm` (Hansen & Travis 1974, eq. 2.29).
double rayleighDepth(double lambdaUm) {
    const double l2 = 1.0 / (lambdaUm * lambdaUm);
    return 0.008569 * l2 * l2 * (1.0 + 0.0113 * l2 + 0.00013 * l2 * l2);
}

struct Depths {
    double rayleigh[3], aerosol[3];
};
Depths opticalDepths(const ClearSky& sky) {
    Depths d{};
    for (int c = 0; c < 3; ++c) {
        d.rayleigh[c] = sky.pressureRatio * rayleighDepth(kLambda[c]);
        d.aerosol[c] = sky.aerosolBeta * std::pow(kLambda[c], -sky.aerosolAlpha);
    }
    return d;
}
Vec3 transmittance(const Depths& d, double airMass) {
    Vec3 t;
    for (int c = 0; c < 3; ++c) t[c] = std::exp(-airMass * (d.rayleigh[c] + d.aerosol[c]));
    return t;
}
double luminance(const Vec3& c) { return kLuma[0] * c.x + kLuma[1] * c.y + kLuma[2] * c.z; }

// The clear sky's diffuse horizontal illuminance relative to a sun at the zenith, as a
// function of the geometric elevation h: ten times dimmer per 2.5 degrees below the horizon
// (a factor 250 over civil twilight, to -6), 0 below astronomical twilight (-18); by day it
// rises from a twentieth at sunset, 0.05 + 0.95 (1 - exp(-sin h / s)) / (1 - exp(-1 / s)), whose
// slope at the horizon, with s = 0.39, is the twilight's: no kink at sunset.
double relativeSkyBrightness(double h) {
    constexpr double kSunset = 0.05, kScale = 0.39;
    if (h >= 0) {
        const double rise =
            -std::expm1(-std::sin(glm::radians(std::min(h, 90.0))) / kScale) / -std::expm1(-1.0 / kScale);
        return kSunset + (1.0 - kSunset) * rise;
    }
    if (h < -18.0) return 0.0;
    return kSunset * std::pow(10.0, h / 2.5);
}

// Fraction of the sun's disc above the horizon with its centre at apparent elevation `e`.
double discFraction(double e) {
    const double x = std::clamp(e / kSunRadiusDeg, -1.0, 1.0);
    return 1.0 - (std::acos(x) - x * std::sqrt(1.0 - x * x)) / std::numbers::pi;
}

double smoothstep(double a, double b, double x) {
    const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

}  // namespace

double julianDay(const UtcTime& t) {
    validate(t);
    int y = t.year, m = t.month;
    if (m <= 2) {
        y -= 1;
        m += 12;
    }
    const int a = y / 100;
    const int b = 2 - a + a / 4;
    const double dayFraction = (t.hour + (t.minute + t.second / 60.0) / 60.0) / 24.0;
    return std::floor(365.25 * (y + 4716)) + std::floor(30.6001 * (m + 1)) + t.day + dayFraction + b - 1524.5;
}

double atmosphericRefractionDeg(double e) {
    if (e > 85.0) return 0.0;
    double arcsec;
    if (e > 5.0) {
        const double t = std::tan(glm::radians(e));
        arcsec = 58.1 / t - 0.07 / (t * t * t) + 0.000086 / std::pow(t, 5);
    } else if (e > -0.575) {
        arcsec = 1735.0 + e * (-518.2 + e * (103.4 + e * (-12.79 + e * 0.711)));
    } else {
        arcsec = -20.772 / std::tan(glm::radians(e));
    }
    return arcsec / 3600.0;
}

SolarPosition solarPosition(const UtcTime& time, double latitudeDeg, double longitudeDeg) {
    require(std::isfinite(latitudeDeg) && latitudeDeg >= -90 && latitudeDeg <= 90, "latitude", "in [-90, 90] degrees",
            latitudeDeg);
    require(std::isfinite(longitudeDeg) && longitudeDeg >= -180 && longitudeDeg <= 180, "longitude",
            "in [-180, 180] degrees", longitudeDeg);
    SolarPosition p;
    p.julianDay = julianDay(time);
    const double jc = (p.julianDay - 2451545.0) / 36525.0;  // Julian centuries from J2000

    // The sun's mean longitude and anomaly, the orbit's eccentricity, the equation of centre.
    const double l0 = wrap360(280.46646 + jc * (36000.76983 + jc * 0.0003032));
    const double m = 357.52911 + jc * (35999.05029 - 0.0001537 * jc);
    const double e = 0.016708634 - jc * (0.000042037 + 0.0000001267 * jc);
    const double mr = glm::radians(m);
    const double c = std::sin(mr) * (1.914602 - jc * (0.004817 + 0.000014 * jc)) +
                     std::sin(2 * mr) * (0.019993 - 0.000101 * jc) + std::sin(3 * mr) * 0.000289;
    const double trueLongitude = l0 + c;
    const double trueAnomaly = m + c;
    p.distanceAu = 1.000001018 * (1 - e * e) / (1 + e * std::cos(glm::radians(trueAnomaly)));

    // Apparent longitude (nutation and aberration) and the obliquity of the ecliptic.
    const double omega = glm::radians(125.04 - 1934.136 * jc);
    const double lambda = glm::radians(trueLongitude - 0.00569 - 0.00478 * std::sin(omega));
    const double meanObliquity =
        23.0 + (26.0 + (21.448 - jc * (46.815 + jc * (0.00059 - jc * 0.001813))) / 60.0) / 60.0;
    const double eps = glm::radians(meanObliquity + 0.00256 * std::cos(omega));

    p.rightAscensionDeg = wrap360(glm::degrees(std::atan2(std::cos(eps) * std::sin(lambda), std::cos(lambda))));
    const double dec = std::asin(std::sin(eps) * std::sin(lambda));
    p.declinationDeg = glm::degrees(dec);

    // Equation of time (Smart 1956, as Meeus eq. 28.3), minutes.
    const double y = std::pow(std::tan(eps / 2), 2);
    const double l0r = glm::radians(l0);
    p.equationOfTimeMin =
        4.0 * glm::degrees(y * std::sin(2 * l0r) - 2 * e * std::sin(mr) + 4 * e * y * std::sin(mr) * std::cos(2 * l0r) -
                           0.5 * y * y * std::sin(4 * l0r) - 1.25 * e * e * std::sin(2 * mr));

    // True solar time and the hour angle (0 at local apparent noon, > 0 after).
    const double minutes = time.hour * 60.0 + time.minute + time.second / 60.0;
    const double trueSolarMin =
        std::fmod(std::fmod(minutes + p.equationOfTimeMin + 4.0 * longitudeDeg, 1440.0) + 1440.0, 1440.0);
    p.hourAngleDeg = trueSolarMin / 4.0 - 180.0;
    if (p.hourAngleDeg <= -180.0) p.hourAngleDeg += 360.0;

    // The direction in east-north-up from the hour angle and declination: well defined at
    // the poles, where the azimuth of the closed formulas is not.
    const double phi = glm::radians(latitudeDeg), ha = glm::radians(p.hourAngleDeg);
    const double east = -std::cos(dec) * std::sin(ha);
    const double north = std::cos(phi) * std::sin(dec) - std::sin(phi) * std::cos(dec) * std::cos(ha);
    const double up = std::sin(phi) * std::sin(dec) + std::cos(phi) * std::cos(dec) * std::cos(ha);
    p.elevationDeg = glm::degrees(std::asin(std::clamp(up, -1.0, 1.0)));
    p.azimuthDeg = wrap360(glm::degrees(std::atan2(east, north)));
    p.refractionDeg = atmosphericRefractionDeg(p.elevationDeg);
    p.apparentElevationDeg = std::min(p.elevationDeg + p.refractionDeg, 90.0);
    p.apparentZenithDeg = 90.0 - p.apparentElevationDeg;
    const double ea = glm::radians(p.apparentElevationDeg), az = glm::radians(p.azimuthDeg);
    p.direction = Vec3(std::cos(ea) * std::sin(az), std::cos(ea) * std::cos(az), std::sin(ea));
    return p;
}

double kastenYoungAirMass(double elevationDeg) {
    const double h = std::max(elevationDeg, -0.9);
    return 1.0 / (std::sin(glm::radians(h)) + 0.50572 * std::pow(h + 6.07995, -1.6364));
}

Daylight daylight(const SolarPosition& position, const ClearSky& sky) {
    require(std::isfinite(sky.aerosolBeta) && sky.aerosolBeta >= 0, "aerosolBeta", ">= 0", sky.aerosolBeta);
    require(std::isfinite(sky.aerosolAlpha) && sky.aerosolAlpha >= 0, "aerosolAlpha", ">= 0", sky.aerosolAlpha);
    require(std::isfinite(sky.pressureRatio) && sky.pressureRatio > 0, "pressureRatio", "> 0", sky.pressureRatio);
    require(std::isfinite(sky.zenithSunIntensity) && sky.zenithSunIntensity > 0, "zenithSunIntensity", "> 0",
            sky.zenithSunIntensity);
    require(std::isfinite(position.elevationDeg) && std::isfinite(position.apparentElevationDeg),
            "position.elevationDeg", "finite", position.elevationDeg);

    Daylight d;
    const Depths depths = opticalDepths(sky);
    // Kasten-Young gives 0.9997 at the zenith: normalising by its own zenith value keeps the
    // zenith sun exactly white.
    const Vec3 zenithT = transmittance(depths, kastenYoungAirMass(90.0));
    const double h = position.elevationDeg;
    const double disc = discFraction(position.apparentElevationDeg);
    d.airMass = disc > 0 ? kastenYoungAirMass(h) : 0.0;
    // Below the horizon the sun keeps the colour of its last light, so that the sky's
    // horizon tint does not jump; its intensity is 0 there through `disc`.
    const Vec3 t = transmittance(depths, kastenYoungAirMass(h));
    d.transmittance = disc > 0 ? t : Vec3(0.0);

    const Vec3 relative = t / zenithT;  // 1 at the zenith, <= 1 below
    const double peak = std::max({relative.x, relative.y, relative.z});
    d.sun.direction = position.direction;
    d.sun.color = relative / peak;
    d.sun.intensity = sky.zenithSunIntensity * peak * disc;

    const double orbit = 1.0 / (position.distanceAu * position.distanceAu);
    d.sunIlluminanceLux = kLuminousSolarConstant * orbit * luminance(d.transmittance) * disc;
    // The zenith sun's diffuse horizontal illuminance, single scattering after Bird & Hulstrom
    // (1981): half the Rayleigh-scattered light and 0.84 of the aerosol-scattered light go down,
    // 0.79 of it survives absorption.
    Vec3 scattered;
    for (int c = 0; c < 3; ++c)
        scattered[c] = 0.5 * (1 - std::exp(-depths.rayleigh[c])) + 0.84 * (1 - std::exp(-depths.aerosol[c]));
    const double skyZenithLux = 0.79 * kLuminousSolarConstant * orbit * luminance(scattered);
    const double brightness = relativeSkyBrightness(h);
    d.skyIlluminanceLux = skyZenithLux * brightness;

    // Sky colours: the zenith sun's sky scaled by the sky's brightness; the horizon takes the
    // sun's colour (at its luminance) as the sun gets low.
    const Sky& s = sky.zenithSunSky;
    const double redden = 1.0 - smoothstep(0.0, 15.0, h);
    const Vec3 sunTint = d.sun.color / luminance(d.sun.color);
    d.sky.zenith = s.zenith * brightness;
    d.sky.horizon = glm::mix(s.horizon, luminance(s.horizon) * sunTint, 0.6 * redden) * brightness;
    // The ground: lit by the direct sun on a horizontal plane plus the sky, relative to a
    // zenith sun.
    const double sunZenithLux = kLuminousSolarConstant * orbit * luminance(zenithT);
    const double sinH = std::max(std::sin(glm::radians(position.apparentElevationDeg)), 0.0);
    const Vec3 groundLight =
        (sunZenithLux * relative * sinH * disc + Vec3(d.skyIlluminanceLux)) / (sunZenithLux + skyZenithLux);
    d.sky.ground = s.ground * groundLight;
    return d;
}

Daylight daylight(const UtcTime& time, double latitudeDeg, double longitudeDeg, const ClearSky& sky) {
    return daylight(solarPosition(time, latitudeDeg, longitudeDeg), sky);
}

}  // namespace nephele
