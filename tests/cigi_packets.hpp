// The CIGI 3.3 packets of the tests, each twice: its bytes written by offset from the standard's
// layout (docs/cigi.md's tables) in either byte order, independently of the codec's own writer,
// and the values they decode to. The codec's tests (cigi_test.cpp) check one against the other;
// `nephele ig`'s (cigi_ig_test.cpp) send the values.
#pragma once

#include "nephele/cigi.hpp"

#include <cstdint>
#include <cstring>
#include <vector>

namespace nephele::cigi::samples {

// Bytes placed by offset: multi-byte values most significant byte first for a big-endian
// sender, least significant first for a little-endian one.
struct Raw {
    std::vector<std::uint8_t> b;
    ByteOrder order;
    Raw(std::size_t size, std::uint8_t op, ByteOrder o) : b(size, 0), order(o) {
        b[0] = op;
        b[1] = static_cast<std::uint8_t>(size);
    }
    void put(std::size_t at, std::uint64_t v, int n) {
        for (int i = 0; i < n; ++i) {
            const int shift = order == ByteOrder::BigEndian ? 8 * (n - 1 - i) : 8 * i;
            b.at(at + i) = static_cast<std::uint8_t>(v >> shift);
        }
    }
    void u8(std::size_t at, std::uint8_t v) { b.at(at) = v; }
    void u16(std::size_t at, std::uint16_t v) { put(at, v, 2); }
    void u32(std::size_t at, std::uint32_t v) { put(at, v, 4); }
    void f32(std::size_t at, float v) {
        std::uint32_t u;
        std::memcpy(&u, &v, 4);
        put(at, u, 4);
    }
    void f64(std::size_t at, double v) {
        std::uint64_t u;
        std::memcpy(&u, &v, 8);
        put(at, u, 8);
    }
};


// IG Control: every field a value that no neighbouring field shares.
inline Raw igControlBytes(ByteOrder o) {
    Raw r(24, 1, o);
    r.u8(2, 3);                               // major version
    r.u8(3, 0xFD);                            // database number -3
    r.u8(4, (3u << 4) | 0x08 | 0x04 | 0x02);  // minor 3, extrapolation, timestamp valid, IG mode Debug
    r.u16(6, 0x8000);                         // the sender's magic, in its order
    r.u32(8, 0x01020304);                     // host frame number
    r.u32(12, 0x0A0B0C0D);                    // timestamp
    r.u32(16, 0x11223344);                    // last IG frame number
    return r;
}
inline IgControl igControlValues() {
    IgControl p;
    p.majorVersion = 3;
    p.minorVersion = 3;
    p.databaseNumber = -3;
    p.igMode = IgMode::Debug;
    p.timestampValid = true;
    p.extrapolationEnable = true;
    p.hostFrameNumber = 0x01020304;
    p.timestamp = 0x0A0B0C0D;
    p.lastIgFrameNumber = 0x11223344;
    return p;
}

inline Raw entityBytes(ByteOrder o) {
    Raw r(48, 2, o);
    r.u16(2, 0x0102);
    r.u8(4, 0x01 | 0x04 | 0x08 | 0x10 | (2u << 5));  // active, attached, collision, inherit alpha, conformal clamp
    r.u8(5, 0x01 | 0x02 | (2u << 2) | 0x10);         // backward, continuous, play, extrapolation
    r.u8(6, 200);
    r.u16(8, 0x0304);
    r.u16(10, 0x0506);
    r.f32(12, 1.5f);
    r.f32(16, -2.25f);
    r.f32(20, 271.125f);
    r.f64(24, 47.123456789);
    r.f64(32, -122.987654321);
    r.f64(40, 1234.5);
    return r;
}
inline EntityControl entityValues() {
    EntityControl p;
    p.entityId = 0x0102;
    p.entityState = 1;
    p.attached = true;
    p.collisionDetectionEnable = true;
    p.inheritAlpha = true;
    p.groundClamp = 2;
    p.animationDirection = 1;
    p.animationLoopMode = 1;
    p.animationState = 2;
    p.extrapolationEnable = true;
    p.alpha = 200;
    p.entityType = 0x0304;
    p.parentId = 0x0506;
    p.roll = 1.5f;
    p.pitch = -2.25f;
    p.yaw = 271.125f;
    p.latitude = 47.123456789;
    p.longitude = -122.987654321;
    p.altitude = 1234.5;
    return p;
}

inline Raw viewControlBytes(ByteOrder o) {
    Raw r(32, 16, o);
    r.u16(2, 0x0708);
    r.u8(4, 9);
    r.u8(5, 0x01 | 0x04 | 0x10 | 0x20);  // x, z, pitch, yaw enabled
    r.u16(6, 0x0A0B);
    r.f32(8, 0.5f);
    r.f32(12, -1.0f);
    r.f32(16, 2.0f);
    r.f32(20, 3.0f);
    r.f32(24, -4.0f);
    r.f32(28, 45.0f);
    return r;
}
inline ViewControl viewControlValues() {
    ViewControl p;
    p.viewId = 0x0708;
    p.groupId = 9;
    p.xOffsetEnable = true;
    p.zOffsetEnable = true;
    p.pitchEnable = true;
    p.yawEnable = true;
    p.entityId = 0x0A0B;
    p.xOffset = 0.5f;
    p.yOffset = -1.0f;
    p.zOffset = 2.0f;
    p.roll = 3.0f;
    p.pitch = -4.0f;
    p.yaw = 45.0f;
    return p;
}

inline Raw viewDefinitionBytes(ByteOrder o) {
    Raw r(32, 21, o);
    r.u16(2, 0x0C0D);
    r.u8(4, 3);
    r.u8(5, 0x01 | 0x02 | 0x04 | 0x08 | 0x20 | (2u << 6));  // near, far, left, right, bottom; mirror vertical
    r.u8(6, 3u | 0x08 | 0x10 | (5u << 5));                  // 2x2 replication, orthographic, reorder, view type 5
    r.f32(8, 0.25f);
    r.f32(12, 90000.0f);
    r.f32(16, -30.0f);
    r.f32(20, 30.5f);
    r.f32(24, 20.0f);
    r.f32(28, -20.5f);
    return r;
}
inline ViewDefinition viewDefinitionValues() {
    ViewDefinition p;
    p.viewId = 0x0C0D;
    p.groupId = 3;
    p.nearEnable = p.farEnable = p.leftEnable = p.rightEnable = p.bottomEnable = true;
    p.mirrorMode = 2;
    p.pixelReplication = 3;
    p.orthographic = true;
    p.reorder = true;
    p.viewType = 5;
    p.nearPlane = 0.25f;
    p.farPlane = 90000.0f;
    p.left = -30.0f;
    p.right = 30.5f;
    p.top = 20.0f;
    p.bottom = -20.5f;
    return p;
}

inline Raw celestialBytes(ByteOrder o) {
    Raw r(16, 9, o);
    r.u8(2, 14);
    r.u8(3, 35);
    r.u8(4, 0x01 | 0x02 | 0x08 | 0x10);  // ephemeris, sun, stars, date valid
    r.u32(8, 6212026);                   // June 21, 2026
    r.f32(12, 75.0f);
    return r;
}
inline CelestialSphereControl celestialValues() {
    CelestialSphereControl p;
    p.hour = 14;
    p.minute = 35;
    p.ephemerisModelEnable = p.sunEnable = p.starFieldEnable = p.dateTimeValid = true;
    p.date = 6212026;
    p.starFieldIntensity = 75.0f;
    return p;
}

inline Raw atmosphereBytes(ByteOrder o) {
    Raw r(32, 10, o);
    r.u8(2, 0x01);
    r.u8(3, 64);
    r.f32(4, 15.5f);
    r.f32(8, 25000.0f);
    r.f32(12, 12.0f);
    r.f32(16, -0.5f);
    r.f32(20, 270.0f);
    r.f32(24, 1013.25f);
    return r;
}
inline AtmosphereControl atmosphereValues() {
    AtmosphereControl p;
    p.atmosphericModelEnable = true;
    p.humidity = 64;
    p.airTemperature = 15.5f;
    p.visibilityRange = 25000.0f;
    p.horizontalWindSpeed = 12.0f;
    p.verticalWindSpeed = -0.5f;
    p.windDirection = 270.0f;
    p.barometricPressure = 1013.25f;
    return p;
}

inline Raw weatherBytes(ByteOrder o) {
    Raw r(56, 12, o);
    r.u16(2, 0x0E0F);
    r.u8(4, 2);                        // cloud layer 2
    r.u8(5, 80);                       // humidity
    r.u8(6, 0x01 | 0x04 | (9u << 4));  // weather enable, random winds, stratocumulus
    r.u8(7, 1u | (4u << 2));           // regional, severity 4
    r.f32(8, -5.0f);
    r.f32(12, 8000.0f);
    r.f32(16, 10.0f);
    r.f32(20, 64.0f);
    r.f32(24, 1500.0f);
    r.f32(28, 600.0f);
    r.f32(32, 50.0f);
    r.f32(36, 7.5f);
    r.f32(40, 0.25f);
    r.f32(44, 225.0f);
    r.f32(48, 990.0f);
    r.f32(52, 0.125f);
    return r;
}
inline WeatherControl weatherValues() {
    WeatherControl p;
    p.entityOrRegionId = 0x0E0F;
    p.layerId = 2;
    p.humidity = 80;
    p.weatherEnable = true;
    p.randomWindsEnable = true;
    p.cloudType = 9;
    p.scope = 1;
    p.severity = 4;
    p.airTemperature = -5.0f;
    p.visibilityRange = 8000.0f;
    p.scudFrequency = 10.0f;
    p.coverage = 64.0f;
    p.baseElevation = 1500.0f;
    p.thickness = 600.0f;
    p.transitionBand = 50.0f;
    p.horizontalWindSpeed = 7.5f;
    p.verticalWindSpeed = 0.25f;
    p.windDirection = 225.0f;
    p.barometricPressure = 990.0f;
    p.aerosolConcentration = 0.125f;
    return p;
}

inline Raw envRequestBytes(ByteOrder o) {
    Raw r(32, 28, o);
    r.u8(2, 4 | 8);  // weather and aerosol
    r.u8(3, 77);
    r.f64(8, 21.3);
    r.f64(16, -157.9);
    r.f64(24, 2500.25);
    return r;
}
inline EnvironmentalConditionsRequest envRequestValues() {
    EnvironmentalConditionsRequest p;
    p.requestType = 12;
    p.requestId = 77;
    p.latitude = 21.3;
    p.longitude = -157.9;
    p.altitude = 2500.25;
    return p;
}

inline Raw startOfFrameBytes(ByteOrder o) {
    Raw r(24, 101, o);
    r.u8(2, 3);
    r.u8(3, 0x7F);                            // database 127
    r.u8(4, 6);                               // IG status
    r.u8(5, (3u << 4) | 0x08 | 0x04 | 0x01);  // minor 3, host-defined earth model, timestamp valid, Operate
    r.u16(6, 0x8000);
    r.u32(8, 0xCAFEBABE);
    r.u32(12, 123456);
    r.u32(16, 0x00ABCDEF);
    return r;
}
inline StartOfFrame startOfFrameValues() {
    StartOfFrame p;
    p.databaseNumber = 127;
    p.igStatus = 6;
    p.igMode = IgMode::Operate;
    p.timestampValid = true;
    p.earthReferenceModel = 1;
    p.igFrameNumber = 0xCAFEBABE;
    p.timestamp = 123456;
    p.lastHostFrameNumber = 0x00ABCDEF;
    return p;
}

inline Raw weatherResponseBytes(ByteOrder o) {
    Raw r(32, 109, o);
    r.u8(2, 77);
    r.u8(3, 55);
    r.f32(4, 12.5f);
    r.f32(8, 3000.0f);
    r.f32(12, 9.0f);
    r.f32(16, -1.5f);
    r.f32(20, 180.0f);
    r.f32(24, 1001.0f);
    return r;
}
inline WeatherConditionsResponse weatherResponseValues() {
    WeatherConditionsResponse p;
    p.requestId = 77;
    p.humidity = 55;
    p.airTemperature = 12.5f;
    p.visibilityRange = 3000.0f;
    p.horizontalWindSpeed = 9.0f;
    p.verticalWindSpeed = -1.5f;
    p.windDirection = 180.0f;
    p.barometricPressure = 1001.0f;
    return p;
}

inline Raw aerosolBytes(ByteOrder o) {
    Raw r(8, 110, o);
    r.u8(2, 77);
    r.u8(3, 2);
    r.f32(4, 0.75f);
    return r;
}
inline AerosolConcentrationResponse aerosolValues() {
    AerosolConcentrationResponse p;
    p.requestId = 77;
    p.layerId = 2;
    p.aerosolConcentration = 0.75f;
    return p;
}

}  // namespace nephele::cigi::samples
