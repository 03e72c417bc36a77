// The CIGI 3.3 codec (cigi/, docs/cigi.md): every packet's bytes are written here by offset from
// the standard's layout (docs/cigi.md's tables), independently of the codec's own writer, in both
// byte orders; each must decode to its fields and the writer must produce exactly those bytes.
// Then malformed datagrams: truncated at every length, size bytes 0 and past the end, unknown
// opcodes, wrong sizes, no IG Control first, a bad byte-swap magic. Last, `nephele ig` on loopback.
#include "cli_run.hpp"
#include "nephele/cigi.hpp"
#include "nephele/geodetic.hpp"
#include "nephele/layer_volume.hpp"
#include "nephele/log.hpp"
#include "nephele/scene.hpp"

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <future>
#include <map>
#include <string>
#include <vector>

using namespace nephele::cigi;

namespace {

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

const ByteOrder kOrders[] = {ByteOrder::BigEndian, ByteOrder::LittleEndian};
const char* orderName(ByteOrder o) { return o == ByteOrder::BigEndian ? "big-endian" : "little-endian"; }

// IG Control: every field a value that no neighbouring field shares.
Raw igControlBytes(ByteOrder o) {
    Raw r(24, 1, o);
    r.u8(2, 3);                                       // major version
    r.u8(3, 0xFD);                                    // database number -3
    r.u8(4, (3u << 4) | 0x08 | 0x04 | 0x02);          // minor 3, extrapolation, timestamp valid, IG mode Debug
    r.u16(6, 0x8000);                                 // the sender's magic, in its order
    r.u32(8, 0x01020304);                             // host frame number
    r.u32(12, 0x0A0B0C0D);                            // timestamp
    r.u32(16, 0x11223344);                            // last IG frame number
    return r;
}
IgControl igControlValues() {
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

Raw entityBytes(ByteOrder o) {
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
EntityControl entityValues() {
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

Raw viewControlBytes(ByteOrder o) {
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
ViewControl viewControlValues() {
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

Raw viewDefinitionBytes(ByteOrder o) {
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
ViewDefinition viewDefinitionValues() {
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

Raw celestialBytes(ByteOrder o) {
    Raw r(16, 9, o);
    r.u8(2, 14);
    r.u8(3, 35);
    r.u8(4, 0x01 | 0x02 | 0x08 | 0x10);  // ephemeris, sun, stars, date valid
    r.u32(8, 6212026);                     // June 21, 2026
    r.f32(12, 75.0f);
    return r;
}
CelestialSphereControl celestialValues() {
    CelestialSphereControl p;
    p.hour = 14;
    p.minute = 35;
    p.ephemerisModelEnable = p.sunEnable = p.starFieldEnable = p.dateTimeValid = true;
    p.date = 6212026;
    p.starFieldIntensity = 75.0f;
    return p;
}

Raw atmosphereBytes(ByteOrder o) {
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
AtmosphereControl atmosphereValues() {
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

Raw weatherBytes(ByteOrder o) {
    Raw r(56, 12, o);
    r.u16(2, 0x0E0F);
    r.u8(4, 2);                          // cloud layer 2
    r.u8(5, 80);                         // humidity
    r.u8(6, 0x01 | 0x04 | (9u << 4));    // weather enable, random winds, stratocumulus
    r.u8(7, 1u | (4u << 2));             // regional, severity 4
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
WeatherControl weatherValues() {
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

Raw envRequestBytes(ByteOrder o) {
    Raw r(32, 28, o);
    r.u8(2, 4 | 8);  // weather and aerosol
    r.u8(3, 77);
    r.f64(8, 21.3);
    r.f64(16, -157.9);
    r.f64(24, 2500.25);
    return r;
}
EnvironmentalConditionsRequest envRequestValues() {
    EnvironmentalConditionsRequest p;
    p.requestType = 12;
    p.requestId = 77;
    p.latitude = 21.3;
    p.longitude = -157.9;
    p.altitude = 2500.25;
    return p;
}

Raw startOfFrameBytes(ByteOrder o) {
    Raw r(24, 101, o);
    r.u8(2, 3);
    r.u8(3, 0x7F);                              // database 127
    r.u8(4, 6);                                 // IG status
    r.u8(5, (3u << 4) | 0x08 | 0x04 | 0x01);    // minor 3, host-defined earth model, timestamp valid, Operate
    r.u16(6, 0x8000);
    r.u32(8, 0xCAFEBABE);
    r.u32(12, 123456);
    r.u32(16, 0x00ABCDEF);
    return r;
}
StartOfFrame startOfFrameValues() {
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

Raw weatherResponseBytes(ByteOrder o) {
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
WeatherConditionsResponse weatherResponseValues() {
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

Raw aerosolBytes(ByteOrder o) {
    Raw r(8, 110, o);
    r.u8(2, 77);
    r.u8(3, 2);
    r.f32(4, 0.75f);
    return r;
}
AerosolConcentrationResponse aerosolValues() {
    AerosolConcentrationResponse p;
    p.requestId = 77;
    p.layerId = 2;
    p.aerosolConcentration = 0.75f;
    return p;
}

std::vector<std::uint8_t> cat(std::initializer_list<std::vector<std::uint8_t>> parts) {
    std::vector<std::uint8_t> out;
    for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
    return out;
}

// Collects the log's messages for the test's lifetime.
struct LogCapture {
    std::vector<std::string> messages;
    nephele::LogCallback previous;
    LogCapture() {
        previous = nephele::setLogCallback(
            [this](nephele::LogLevel, std::string_view m) { messages.emplace_back(m); });
    }
    ~LogCapture() { nephele::setLogCallback(previous); }
    bool any(const std::string& part) const {
        for (const auto& m : messages)
            if (m.find(part) != std::string::npos) return true;
        return false;
    }
};

// One host packet after IG Control: decodes from the hand-built bytes, and the writer writes
// exactly those bytes.
template <class P>
void checkHostPacket(Raw (*bytes)(ByteOrder), P (*values)()) {
    for (ByteOrder o : kOrders) {
        SCOPED_TRACE(orderName(o));
        const std::vector<std::uint8_t> datagram = cat({igControlBytes(o).b, bytes(o).b});
        const auto d = parseHostDatagram(datagram);
        ASSERT_TRUE(d.has_value());
        EXPECT_EQ(d->byteOrder, o);
        EXPECT_TRUE(d->complete);
        EXPECT_EQ(d->skipped, 0);
        ASSERT_EQ(d->packets.size(), 1u);
        ASSERT_TRUE(std::holds_alternative<P>(d->packets[0]));
        EXPECT_TRUE(std::get<P>(d->packets[0]) == values());

        DatagramWriter w(o);
        w.add(igControlValues());
        w.add(values());
        EXPECT_EQ(w.bytes(), datagram);
    }
}

template <class P>
void checkIgPacket(Raw (*bytes)(ByteOrder), P (*values)()) {
    for (ByteOrder o : kOrders) {
        SCOPED_TRACE(orderName(o));
        const std::vector<std::uint8_t> datagram = cat({startOfFrameBytes(o).b, bytes(o).b});
        const auto d = parseIgDatagram(datagram);
        ASSERT_TRUE(d.has_value());
        EXPECT_EQ(d->byteOrder, o);
        EXPECT_TRUE(d->startOfFrame == startOfFrameValues());
        ASSERT_EQ(d->packets.size(), 1u);
        ASSERT_TRUE(std::holds_alternative<P>(d->packets[0]));
        EXPECT_TRUE(std::get<P>(d->packets[0]) == values());

        DatagramWriter w(o);
        w.add(startOfFrameValues());
        w.add(values());
        EXPECT_EQ(w.bytes(), datagram);
    }
}

}  // namespace

TEST(CigiTest, PacketSizesAreTheStandards) {
    EXPECT_EQ(packetSize(opcode::IgControl), 24u);
    EXPECT_EQ(packetSize(opcode::EntityControl), 48u);
    EXPECT_EQ(packetSize(opcode::CelestialSphereControl), 16u);
    EXPECT_EQ(packetSize(opcode::AtmosphereControl), 32u);
    EXPECT_EQ(packetSize(opcode::WeatherControl), 56u);
    EXPECT_EQ(packetSize(opcode::ViewControl), 32u);
    EXPECT_EQ(packetSize(opcode::ViewDefinition), 32u);
    EXPECT_EQ(packetSize(opcode::EnvironmentalConditionsRequest), 32u);
    EXPECT_EQ(packetSize(opcode::StartOfFrame), 24u);
    EXPECT_EQ(packetSize(opcode::WeatherConditionsResponse), 32u);
    EXPECT_EQ(packetSize(opcode::AerosolConcentrationResponse), 8u);
    EXPECT_EQ(packetSize(200), 0u);
}

TEST(CigiTest, IgControlDecodesInBothByteOrders) {
    for (ByteOrder o : kOrders) {
        SCOPED_TRACE(orderName(o));
        const Raw r = igControlBytes(o);
        // The magic as it sits on the wire: 0x80 0x00 from a big-endian sender, 0x00 0x80 from a little-endian one.
        EXPECT_EQ(r.b[6], o == ByteOrder::BigEndian ? 0x80 : 0x00);
        const auto d = parseHostDatagram(r.b);
        ASSERT_TRUE(d.has_value());
        EXPECT_EQ(d->byteOrder, o);
        EXPECT_TRUE(d->igControl == igControlValues());
        EXPECT_TRUE(d->packets.empty());
        DatagramWriter w(o);
        w.add(igControlValues());
        EXPECT_EQ(w.bytes(), r.b);
    }
}

TEST(CigiTest, EntityControl) { checkHostPacket(entityBytes, entityValues); }
TEST(CigiTest, ViewControl) { checkHostPacket(viewControlBytes, viewControlValues); }
TEST(CigiTest, ViewDefinition) { checkHostPacket(viewDefinitionBytes, viewDefinitionValues); }
TEST(CigiTest, CelestialSphereControl) { checkHostPacket(celestialBytes, celestialValues); }
TEST(CigiTest, AtmosphereControl) { checkHostPacket(atmosphereBytes, atmosphereValues); }
TEST(CigiTest, WeatherControl) { checkHostPacket(weatherBytes, weatherValues); }
TEST(CigiTest, EnvironmentalConditionsRequest) { checkHostPacket(envRequestBytes, envRequestValues); }
TEST(CigiTest, WeatherConditionsResponse) { checkIgPacket(weatherResponseBytes, weatherResponseValues); }
TEST(CigiTest, AerosolConcentrationResponse) { checkIgPacket(aerosolBytes, aerosolValues); }

TEST(CigiTest, StartOfFrameDecodesInBothByteOrders) {
    for (ByteOrder o : kOrders) {
        SCOPED_TRACE(orderName(o));
        const Raw r = startOfFrameBytes(o);
        const auto d = parseIgDatagram(r.b);
        ASSERT_TRUE(d.has_value());
        EXPECT_EQ(d->byteOrder, o);
        EXPECT_TRUE(d->startOfFrame == startOfFrameValues());
        DatagramWriter w(o);
        w.add(startOfFrameValues());
        EXPECT_EQ(w.bytes(), r.b);
    }
}

// A whole frame written and read back: every packet, in order, both byte orders.
TEST(CigiTest, WriterRoundTripsAFrame) {
    for (ByteOrder o : kOrders) {
        SCOPED_TRACE(orderName(o));
        const std::vector<HostPacket> packets = {viewDefinitionValues(), viewControlValues(), entityValues(),
                                                 celestialValues(),      atmosphereValues(),  weatherValues(),
                                                 weatherValues(),        envRequestValues()};
        DatagramWriter w(o);
        w.add(igControlValues());
        for (const HostPacket& p : packets) w.add(p);
        const auto d = parseHostDatagram(w.bytes());
        ASSERT_TRUE(d.has_value());
        EXPECT_TRUE(d->complete);
        EXPECT_TRUE(d->igControl == igControlValues());
        EXPECT_TRUE(d->packets == packets);

        DatagramWriter ig(o);
        ig.add(startOfFrameValues());
        ig.add(weatherResponseValues());
        ig.add(aerosolValues());
        ig.add(aerosolValues());
        const auto r = parseIgDatagram(ig.bytes());
        ASSERT_TRUE(r.has_value());
        EXPECT_TRUE(r->startOfFrame == startOfFrameValues());
        ASSERT_EQ(r->packets.size(), 3u);
        EXPECT_TRUE(std::get<AerosolConcentrationResponse>(r->packets[2]) == aerosolValues());
    }
}

// Every prefix of a valid datagram: under 24 bytes no IG Control, so dropped; after that, the
// packets wholly inside the prefix and nothing else, and `complete` only at a packet boundary.
TEST(CigiTest, TruncationAtEveryLength) {
    LogCapture log;
    const ByteOrder o = ByteOrder::BigEndian;
    const std::vector<std::uint8_t> full =
        cat({igControlBytes(o).b, weatherBytes(o).b, entityBytes(o).b, aerosolBytes(o).b /* stray: skipped */});
    for (std::size_t n = 0; n <= full.size(); ++n) {
        SCOPED_TRACE("length " + std::to_string(n));
        // A copy of exactly n bytes, so that AddressSanitizer sees any read past it.
        const std::vector<std::uint8_t> prefix(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(n));
        const auto d = parseHostDatagram(prefix);
        if (n < 24) {
            EXPECT_FALSE(d.has_value());
            continue;
        }
        ASSERT_TRUE(d.has_value());
        const std::size_t whole = (n >= 24 + 56) + (n >= 24 + 56 + 48);
        EXPECT_EQ(d->packets.size(), whole);
        const bool boundary = n == 24 || n == 80 || n == 128 || n == 136;
        EXPECT_EQ(d->complete, boundary);
        EXPECT_EQ(d->skipped, n == 136 ? 1 : 0);
    }
    EXPECT_TRUE(log.any("shorter than its first packet"));
    EXPECT_TRUE(log.any("only"));  // "declares 56 bytes but only 10 remain"
}

TEST(CigiTest, SizeByteZeroOrOneEndsTheDatagram) {
    for (std::uint8_t size : {0, 1}) {
        LogCapture log;
        Raw bad = weatherBytes(ByteOrder::BigEndian);
        bad.b[1] = size;
        const auto d = parseHostDatagram(cat({igControlBytes(ByteOrder::BigEndian).b, bad.b, entityBytes(ByteOrder::BigEndian).b}));
        ASSERT_TRUE(d.has_value());
        EXPECT_FALSE(d->complete);
        EXPECT_TRUE(d->packets.empty());  // the entity after it is not reached
        EXPECT_TRUE(log.any("declares a size of " + std::to_string(size)));
    }
}

TEST(CigiTest, SizePastTheEndEndsTheDatagram) {
    LogCapture log;
    Raw bad = entityBytes(ByteOrder::BigEndian);
    bad.b[1] = 200;
    const auto d = parseHostDatagram(cat({igControlBytes(ByteOrder::BigEndian).b, weatherBytes(ByteOrder::BigEndian).b, bad.b}));
    ASSERT_TRUE(d.has_value());
    EXPECT_FALSE(d->complete);
    ASSERT_EQ(d->packets.size(), 1u);  // the weather before it is kept
    EXPECT_TRUE(std::get<WeatherControl>(d->packets[0]) == weatherValues());
    EXPECT_TRUE(log.any("Entity Control, opcode 2) declares 200 bytes but only 48 remain"));
}

TEST(CigiTest, UnknownOpcodesAreSkippedBySize) {
    LogCapture log;
    const ByteOrder o = ByteOrder::LittleEndian;
    std::vector<std::uint8_t> unknown(16, 0xEE);
    unknown[0] = 200;  // user-defined
    unknown[1] = 16;
    std::vector<std::uint8_t> odd = {77, 3, 0xFF};  // an opcode no CIGI 3.3 packet has, odd size
    const auto d = parseHostDatagram(cat({igControlBytes(o).b, unknown, weatherBytes(o).b, odd, entityBytes(o).b}));
    ASSERT_TRUE(d.has_value());
    EXPECT_TRUE(d->complete);
    EXPECT_EQ(d->skipped, 2);
    ASSERT_EQ(d->packets.size(), 2u);
    EXPECT_TRUE(std::get<WeatherControl>(d->packets[0]) == weatherValues());
    EXPECT_TRUE(std::get<EntityControl>(d->packets[1]) == entityValues());
}

TEST(CigiTest, KnownOpcodeOfTheWrongSizeIsSkipped) {
    LogCapture log;
    const ByteOrder o = ByteOrder::BigEndian;
    std::vector<std::uint8_t> shortWeather = weatherBytes(o).b;
    shortWeather.resize(48);  // a 48-byte "Weather Control": not CIGI 3.3's
    shortWeather[1] = 48;
    const auto d = parseHostDatagram(cat({igControlBytes(o).b, shortWeather, entityBytes(o).b}));
    ASSERT_TRUE(d.has_value());
    EXPECT_TRUE(d->complete);
    EXPECT_EQ(d->skipped, 1);
    ASSERT_EQ(d->packets.size(), 1u);
    EXPECT_TRUE(std::holds_alternative<EntityControl>(d->packets[0]));
    EXPECT_TRUE(log.any("Weather Control at offset 24 declares 48 bytes; CIGI 3.3 has 56"));
}

TEST(CigiTest, DatagramWithoutIgControlFirstIsDropped) {
    const ByteOrder o = ByteOrder::BigEndian;
    {
        LogCapture log;
        EXPECT_FALSE(parseHostDatagram(cat({weatherBytes(o).b, igControlBytes(o).b})).has_value());
        EXPECT_TRUE(log.any("first packet has opcode 12, not IG Control (1)"));
    }
    {
        LogCapture log;
        Raw igc = igControlBytes(o);
        igc.b[1] = 16;  // CIGI 3.0/3.1's IG Control size
        EXPECT_FALSE(parseHostDatagram(igc.b).has_value());
        EXPECT_TRUE(log.any("declares 16 bytes; CIGI 3.3 has 24"));
    }
    {
        LogCapture log;
        Raw igc = igControlBytes(o);
        igc.b[2] = 2;
        EXPECT_FALSE(parseHostDatagram(igc.b).has_value());
        EXPECT_TRUE(log.any("major version 2"));
    }
    {
        LogCapture log;
        Raw igc = igControlBytes(o);
        igc.b[6] = 0x12;
        igc.b[7] = 0x34;
        EXPECT_FALSE(parseHostDatagram(igc.b).has_value());
        EXPECT_TRUE(log.any("magic number 4660"));
    }
    {
        LogCapture log;
        EXPECT_FALSE(parseHostDatagram({}).has_value());
        EXPECT_FALSE(parseIgDatagram(igControlBytes(o).b).has_value());  // a host's datagram is not an IG's
    }
}

// The IG's own packets and a second IG Control inside a host datagram do not belong there.
TEST(CigiTest, PacketsOfTheOtherSideAreSkipped) {
    LogCapture log;
    const ByteOrder o = ByteOrder::BigEndian;
    const auto d = parseHostDatagram(cat({igControlBytes(o).b, startOfFrameBytes(o).b, igControlBytes(o).b, aerosolBytes(o).b,
                                          weatherBytes(o).b}));
    ASSERT_TRUE(d.has_value());
    EXPECT_EQ(d->skipped, 3);
    ASSERT_EQ(d->packets.size(), 1u);
    EXPECT_TRUE(log.any("Start of Frame at offset 24 does not belong here"));
}

namespace {

// A host's UDP socket on 127.0.0.1, its receive bounded by `timeoutMs`.
struct HostSocket {
    int fd = -1;
    explicit HostSocket(int timeoutMs) {
        fd = ::socket(AF_INET, SOCK_DGRAM, 0);
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
        timeval tv{timeoutMs / 1000, (timeoutMs % 1000) * 1000};
        ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    }
    ~HostSocket() { ::close(fd); }
    void send(const std::vector<std::uint8_t>& bytes, int port) const {
        sockaddr_in to{};
        to.sin_family = AF_INET;
        to.sin_port = htons(static_cast<std::uint16_t>(port));
        to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        ::sendto(fd, bytes.data(), bytes.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
    }
    std::vector<std::uint8_t> receive() const {
        std::vector<std::uint8_t> b(65536);
        const ssize_t n = ::recv(fd, b.data(), b.size(), 0);
        b.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
        return b;
    }
};

// A UDP port nobody holds at the moment of asking (the kernel's pick for port 0).
int freePort() {
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    socklen_t len = sizeof a;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    ::close(fd);
    return ntohs(a.sin_port);
}

}  // namespace

// `nephele ig` as one channel of a host on loopback: three host frames, each answered by a
// Start of Frame that names it, with the IG's counter advancing; a Weather Control in frame 2;
// an Environmental Conditions Request in frame 3 answered in the same datagram; frames recorded.
TEST(CigiIgTest, AnswersThreeFramesWithAdvancingStartOfFrame) {
    const int port = freePort();
    const std::string record = std::string(NEPHELE_TEST_OUTPUT) + "/cigi-ig-record";
    std::filesystem::remove_all(record);
    const std::string args = "ig " + std::string(NEPHELE_SCENES) + "/layer_flight.json --width 48 --height 27 --port " +
                             std::to_string(port) + " --channel 0 --headless --frames 3 --timeout 30 --record " + record;
    auto ig = std::async(std::launch::async, [&] { return nephele::test::runBounded(args, 4096, 240); });

    HostSocket host(1000);
    std::map<std::uint32_t, StartOfFrame> answers;  // by the host frame number answered
    std::vector<IgPacket> frame3Responses;
    std::uint32_t lastIg = 0;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(200);
    for (std::uint32_t frame = 1; frame <= 3 && std::chrono::steady_clock::now() < deadline;) {
        DatagramWriter w(frame == 2 ? ByteOrder::LittleEndian : ByteOrder::BigEndian);  // either order is answered
        IgControl igc;
        igc.hostFrameNumber = frame;
        igc.lastIgFrameNumber = lastIg;
        w.add(igc);
        if (frame == 2) {
            WeatherControl wc = weatherValues();
            wc.layerId = 1;
            wc.scope = 0;
            wc.cloudType = 7;
            w.add(wc);
        }
        if (frame == 3) w.add(envRequestValues());
        host.send(w.bytes(), port);  // resent each second until answered: the IG may still be starting
        const std::vector<std::uint8_t> reply = host.receive();
        const auto d = parseIgDatagram(reply);
        if (!d || d->startOfFrame.lastHostFrameNumber != frame) continue;
        answers[frame] = d->startOfFrame;
        lastIg = d->startOfFrame.igFrameNumber;
        if (frame == 3) frame3Responses = d->packets;
        ++frame;
    }
    const nephele::test::BoundedRun run = ig.get();
    EXPECT_EQ(run.code, 0) << run.output;
    ASSERT_EQ(answers.size(), 3u) << run.output;
    for (std::uint32_t f = 1; f <= 3; ++f) {
        EXPECT_EQ(answers[f].lastHostFrameNumber, f);
        EXPECT_EQ(answers[f].igMode, IgMode::Operate);
        EXPECT_EQ(answers[f].majorVersion, 3);
        EXPECT_EQ(answers[f].minorVersion, 3);
    }
    EXPECT_EQ(answers[1].igFrameNumber, 1u);
    EXPECT_EQ(answers[2].igFrameNumber, 2u);
    EXPECT_EQ(answers[3].igFrameNumber, 3u);
    // Weather (request type 4) and aerosol (8): the atmosphere's response and one per enabled layer.
    ASSERT_FALSE(frame3Responses.empty());
    ASSERT_TRUE(std::holds_alternative<WeatherConditionsResponse>(frame3Responses[0]));
    EXPECT_EQ(std::get<WeatherConditionsResponse>(frame3Responses[0]).requestId, envRequestValues().requestId);
    EXPECT_GE(frame3Responses.size(), 2u);
    for (std::uint32_t f = 1; f <= 3; ++f) {
        char name[64];
        std::snprintf(name, sizeof name, "/host-frame-%010u.pfm", f);
        EXPECT_TRUE(std::filesystem::exists(record + name)) << name;
    }
    EXPECT_NE(run.output.find("3 frames drawn"), std::string::npos) << run.output;
}

// Environmental Conditions Requests are answered with the cloud water at the point: the
// extinction the cloud queries give there (the layer's, 6-9 km from the eye: no near LOD, no rim),
// as liquid water in 10 um droplets, for the layer whose slab holds the point and 0 for the others
// and outside every slab. The expected value is the path tracer's layer field (LayerVolumes) at
// the same point and time; the request travels as latitude, longitude and altitude about --origin.
TEST(CigiIgTest, AerosolAnswersAreTheCloudWaterAtThePoint) {
    const std::string file = std::string(NEPHELE_SCENES) + "/layer_flight.json";
    const nephele::Scene scene = nephele::loadScene(file);
    const double t = 2 / 60.0;  // frame 2, no timestamp: the host frame number at 60 Hz
    const nephele::Vec3 eye = nephele::cameraAt(scene, t).position;
    const nephele::LayerVolumes field(scene, nephele::LayeredSettings{}, t);
    const nephele::Layer& layer = scene.layers.at(0);
    // The densest of a ring of points in the layer: the answer must be the field's, not 0.
    nephele::Vec3 dense(0.0);
    double densest = 0;
    for (int k = 0; k < 720; ++k) {
        const double a = k * 0.5 * 3.14159265358979 / 180, r = 6000 + 3000 * ((k * 7) % 11) / 10.0;
        const nephele::Vec3 p = eye + nephele::Vec3(r * std::cos(a), r * std::sin(a), 0);
        const nephele::Vec3 q(p.x, p.y, layer.base + 0.4 * layer.thickness);
        if (const double s = field.extinction(q, eye); s > densest) densest = s, dense = q;
    }
    ASSERT_GT(densest, 1e-3);
    const nephele::Geodetic origin{47.5, 8.5, 400};  // --origin
    const nephele::EnuFrame enu(origin);
    auto request = [&](std::uint8_t id, const nephele::Vec3& p) {
        const nephele::Geodetic g = enu.enuToGeodetic(p);
        EnvironmentalConditionsRequest r;
        r.requestType = 8;
        r.requestId = id;
        r.latitude = g.latitudeDeg, r.longitude = g.longitudeDeg, r.altitude = g.heightM;
        return r;
    };
    const int port = freePort();
    const std::string args = "ig " + file + " --width 32 --height 18 --port " + std::to_string(port) +
                             " --headless --frames 2 --timeout 30 --origin 47.5,8.5,400";
    auto ig = std::async(std::launch::async, [&] { return nephele::test::runBounded(args, 4096, 240); });
    HostSocket host(1000);
    std::vector<IgPacket> answers;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(200);
    for (std::uint32_t frame = 1; frame <= 2 && std::chrono::steady_clock::now() < deadline;) {
        DatagramWriter w(ByteOrder::BigEndian);
        IgControl igc;
        igc.hostFrameNumber = frame;
        w.add(igc);
        if (frame == 2) {
            w.add(request(1, dense));
            w.add(request(2, dense + nephele::Vec3(0, 0, layer.thickness)));  // above the slab
        }
        host.send(w.bytes(), port);
        const auto d = parseIgDatagram(host.receive());
        if (!d || d->startOfFrame.lastHostFrameNumber != frame) continue;
        if (frame == 2) answers = d->packets;
        ++frame;
    }
    const nephele::test::BoundedRun run = ig.get();
    EXPECT_EQ(run.code, 0) << run.output;
    std::map<int, double> water;  // by request id: layer 1's answer
    for (const IgPacket& p : answers)
        if (const auto* a = std::get_if<AerosolConcentrationResponse>(&p)) {
            EXPECT_EQ(a->layerId, 1);  // the scene's one layer
            water[a->requestId] = a->aerosolConcentration;
        }
    ASSERT_EQ(water.size(), 2u) << run.output;
    const double expected = nephele::liquidWaterFromExtinction(densest, nephele::kCumulusDropletRadius);
    std::printf("[ figure ] cloud water at the point: %.6g g/m^3 answered, %.6g expected (extinction %.4g /m)\n", water[1],
                expected, densest);
    // The float of the packet, and the drift summed frame by frame against wind x t: 1e-3.
    EXPECT_NEAR(water[1], expected, 1e-3 * expected + 1e-7);
    EXPECT_EQ(water[2], 0.0);
}

TEST(CigiIgTest, ABadOriginIsRefusedBeforeAnyWork) {
    for (const char* origin : {"91,0,0", "47.5,8.5", "47.5,nan,0", "1,2,3x", "0,0,200000"}) {
        const nephele::test::BoundedRun run = nephele::test::runBounded(
            "ig " + std::string(NEPHELE_SCENES) + "/layer_flight.json --port " + std::to_string(freePort()) +
                " --headless --origin " + origin,
            4096, 60);
        EXPECT_EQ(run.code, 2) << origin << "\n" << run.output;
        EXPECT_NE(run.output.find("--origin"), std::string::npos) << run.output;
        EXPECT_EQ(run.output.find("listening"), std::string::npos) << run.output;
    }
}

TEST(CigiIgTest, TimesOutBeforeItsFramesWithExit1) {
    const nephele::test::BoundedRun run = nephele::test::runBounded(
        "ig " + std::string(NEPHELE_SCENES) + "/layer_flight.json --width 16 --height 9 --port " + std::to_string(freePort()) +
            " --headless --frames 2 --timeout 0.5",
        4096, 120);
    EXPECT_EQ(run.code, 1) << run.output;
    EXPECT_NE(run.output.find("no datagram from the host for 0.5 s after 0 of 2 frames"), std::string::npos) << run.output;
}
