// WGS84 geodetic <-> ECEF <-> local east-north-up. Formulas: docs/embedding.md,
// "Time of day and geodetic frame".
#include "nephele/geodetic.hpp"

#include <glm/trigonometric.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace nephele {
namespace {

void validate(const Geodetic& g) {
    if (!std::isfinite(g.latitudeDeg) || g.latitudeDeg < -90 || g.latitudeDeg > 90)
        throw std::invalid_argument("latitude: must be in [-90, 90] degrees, got " + std::to_string(g.latitudeDeg));
    if (!std::isfinite(g.longitudeDeg))
        throw std::invalid_argument("longitude: must be finite, got " + std::to_string(g.longitudeDeg));
    if (!std::isfinite(g.heightM))
        throw std::invalid_argument("height: must be finite, got " + std::to_string(g.heightM));
}

}  // namespace

Vec3 geodeticToEcef(const Geodetic& g) {
    validate(g);
    const double phi = glm::radians(g.latitudeDeg), lambda = glm::radians(g.longitudeDeg);
    const double s = std::sin(phi), c = std::cos(phi);
    const double n = kWgs84A / std::sqrt(1.0 - kWgs84E2 * s * s);  // prime vertical radius of curvature
    return {(n + g.heightM) * c * std::cos(lambda), (n + g.heightM) * c * std::sin(lambda),
            (n * (1.0 - kWgs84E2) + g.heightM) * s};
}

Geodetic ecefToGeodetic(const Vec3& x) {
    if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z))
        throw std::invalid_argument("ecef: must be finite");
    if (glm::length(x) < 100e3) throw std::invalid_argument("ecef: the point is within 100 km of the Earth's centre");
    const double p = std::hypot(x.x, x.y);
    // phi = atan2(z + e2 N(phi) sin(phi), p): each step shrinks the error by about e2 (1/150).
    double phi = std::atan2(x.z, p * (1.0 - kWgs84E2));
    for (int i = 0; i < 8; ++i) {
        const double s = std::sin(phi);
        const double n = kWgs84A / std::sqrt(1.0 - kWgs84E2 * s * s);
        phi = std::atan2(x.z + kWgs84E2 * n * s, p);
    }
    const double s = std::sin(phi), c = std::cos(phi);
    Geodetic g;
    g.latitudeDeg = glm::degrees(phi);
    g.longitudeDeg = p > 0 ? glm::degrees(std::atan2(x.y, x.x)) : 0.0;
    // h = p cos(phi) + z sin(phi) - a^2 / N: no division by cos(phi), so exact at the poles too.
    g.heightM = p * c + x.z * s - kWgs84A * std::sqrt(1.0 - kWgs84E2 * s * s);
    return g;
}

EnuFrame::EnuFrame(const Geodetic& origin) : origin_(origin), originEcef_(geodeticToEcef(origin)) {
    const double phi = glm::radians(origin.latitudeDeg), lambda = glm::radians(origin.longitudeDeg);
    const double sp = std::sin(phi), cp = std::cos(phi), sl = std::sin(lambda), cl = std::cos(lambda);
    east_ = {-sl, cl, 0.0};
    north_ = {-sp * cl, -sp * sl, cp};
    up_ = {cp * cl, cp * sl, sp};
}

Vec3 EnuFrame::ecefToEnu(const Vec3& ecef) const { return ecefDirectionToEnu(ecef - originEcef_); }

Vec3 EnuFrame::enuToEcef(const Vec3& enu) const { return originEcef_ + enuDirectionToEcef(enu); }

}  // namespace nephele
