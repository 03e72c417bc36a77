// The CIGI 3.3 codec (cigi/, docs/cigi.md): every packet's bytes are written by offset from
// the standard's layout (cigi_packets.hpp), independently of the codec's own writer, in both
// byte orders; each must decode to its fields and the writer must produce exactly those bytes.
// Then malformed datagrams: truncated at every length, size bytes 0 and past the end, unknown
// opcodes, wrong sizes, no IG Control first, a bad byte-swap magic. `nephele ig` on loopback is
// cigi_ig_test.cpp's.
#include "cigi_packets.hpp"
#include "nephele/cigi.hpp"
#include "nephele/cigi_scene.hpp"
#include "nephele/geodetic.hpp"
#include "nephele/log.hpp"
#include "nephele/scene.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

using namespace nephele::cigi;
using namespace nephele::cigi::samples;

namespace {

const ByteOrder kOrders[] = {ByteOrder::BigEndian, ByteOrder::LittleEndian};
const char* orderName(ByteOrder o) { return o == ByteOrder::BigEndian ? "big-endian" : "little-endian"; }

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
        previous = nephele::setLogCallback([this](nephele::LogLevel, std::string_view m) { messages.emplace_back(m); });
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
        const auto d = parseHostDatagram(
            cat({igControlBytes(ByteOrder::BigEndian).b, bad.b, entityBytes(ByteOrder::BigEndian).b}));
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
    const auto d =
        parseHostDatagram(cat({igControlBytes(ByteOrder::BigEndian).b, weatherBytes(ByteOrder::BigEndian).b, bad.b}));
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
    const auto d = parseHostDatagram(
        cat({igControlBytes(o).b, startOfFrameBytes(o).b, igControlBytes(o).b, aerosolBytes(o).b, weatherBytes(o).b}));
    ASSERT_TRUE(d.has_value());
    EXPECT_EQ(d->skipped, 3);
    ASSERT_EQ(d->packets.size(), 1u);
    EXPECT_TRUE(log.any("Start of Frame at offset 24 does not belong here"));
}

namespace {

// A packet as `nephele ig` gets it: written by the codec, read back from the datagram.
template <class P>
P throughTheCodec(const P& packet) {
    DatagramWriter w(ByteOrder::LittleEndian);
    w.add(IgControl{});
    w.add(packet);
    const auto d = parseHostDatagram(w.bytes());
    EXPECT_TRUE(d.has_value());
    if (!d || d->packets.size() != 1 || !std::holds_alternative<P>(d->packets[0])) {
        ADD_FAILURE() << "the packet did not come back";
        return packet;
    }
    return std::get<P>(d->packets[0]);
}

CelestialSphereControl celestial(std::uint32_t date, int hour, int minute, bool valid = true, bool sun = true) {
    CelestialSphereControl c;
    c.date = date;
    c.hour = std::uint8_t(hour), c.minute = std::uint8_t(minute);
    c.dateTimeValid = valid;
    c.sunEnable = sun;
    return throughTheCodec(c);
}

double elevationDeg(const nephele::Vec3& direction) { return std::asin(direction.z) * 180 / 3.14159265358979323846; }

}  // namespace

// Celestial Sphere Control's date (MMDDYYYY) and time (UTC) at --origin's latitude and
// longitude light the scene as nephele::daylight does; its flags say what is applied.
TEST(CigiTest, CelestialSphereControlSetsTheSunOfItsDateAndTime) {
    // Toulouse, 21 June 2026 18:30 UTC (the docs/embedding.md example): the daylight of that instant.
    const double lat = 43.6045, lon = 1.4440;
    CelestialLight day;
    const CelestialLight evening = applyCelestial(celestial(6212026, 18, 30), lat, lon, day);
    const nephele::Daylight expected = nephele::daylight(nephele::UtcTime{2026, 6, 21, 18, 30, 0}, lat, lon);
    EXPECT_EQ(evening.sun, expected.sun);
    EXPECT_EQ(evening.sky, expected.sky);
    EXPECT_EQ(day.sun, expected.sun);  // the light the next packets start from
    // The decimal date read as MMDDYYYY, not DDMMYYYY or YYYYMMDD: the equinox (20 March) at noon
    // UTC on the equator at Greenwich has the sun within 3 degrees of the zenith (declination
    // -0.1, equation of time -7.5 min: 1.9 degrees of hour angle); at midnight it is down.
    EXPECT_GT(elevationDeg(applyCelestial(celestial(3202026, 12, 0), 0, 0, day).sun.direction), 87.0);
    const CelestialLight midnight = applyCelestial(celestial(3202026, 0, 0), 0, 0, day);
    EXPECT_LT(elevationDeg(midnight.sun.direction), -80.0);
    EXPECT_EQ(midnight.sun.intensity, 0.0);
    // 1 January (01012026, written 1012026) at 10:00 UTC in Toulouse: a low winter sun. By hand:
    // declination -23.0, equation of time -3.4 min, so hour angle -29.4 and elevation 18.1
    // (geometric; refraction adds 0.05).
    EXPECT_NEAR(elevationDeg(applyCelestial(celestial(1012026, 10, 0), lat, lon, day).sun.direction), 18.15, 0.2);
    // Date/Time Valid clear: the light stays what it was; Sun Enable clear: no sunlight, the sky's stays.
    day = {};
    const CelestialLight unchanged = applyCelestial(celestial(6212026, 18, 30, false), lat, lon, day);
    EXPECT_EQ(unchanged.sun, nephele::Sun{});
    const CelestialLight off = applyCelestial(celestial(6212026, 12, 0, true, false), lat, lon, day);
    EXPECT_EQ(off.sun.intensity, 0.0);
    EXPECT_GT(day.sun.intensity, 1.0);  // noon in June: the sun is there, only switched off
    EXPECT_EQ(off.sky, day.sky);
    EXPECT_GT(applyCelestial(celestial(6212026, 12, 0, false, true), lat, lon, day).sun.intensity, 1.0);  // on again
    // Out of range: named, and the light kept.
    const CelestialLight before = day;
    for (const auto& [date, field] :
         std::vector<std::pair<std::uint32_t, std::string>>{{13012026, "month"}, {2302026, "day"}, {6211500, "year"}}) {
        try {
            applyCelestial(celestial(date, 12, 0), lat, lon, day);
            ADD_FAILURE() << date << " accepted";
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
        }
        EXPECT_EQ(day.sun, before.sun);
    }
    EXPECT_THROW(applyCelestial(celestial(6212026, 24, 0), lat, lon, day), std::invalid_argument);
}

// Entity Control's geodetic position and attitude, in the scene's east-north-up frame (--origin).
TEST(CigiTest, EntityControlIsAPoseInTheScenesFrame) {
    const nephele::EnuFrame frame(nephele::Geodetic{47.5, 8.5, 400});
    auto pose = [&](double lat, double lon, double alt, float yaw, float pitch, float roll) {
        EntityControl e;
        e.entityState = 1;
        e.latitude = lat, e.longitude = lon, e.altitude = alt;
        e.yaw = yaw, e.pitch = pitch, e.roll = roll;
        return entityPose(throughTheCodec(e), frame);
    };
    auto near = [](const nephele::Vec3& a, const nephele::Vec3& b, double tolerance) {
        return glm::length(a - b) <= tolerance;
    };
    const double s30 = 0.5, c30 = std::sqrt(3.0) / 2;
    // 1 km above the origin: the heading clockwise from north, the pitch nose up, the roll right wing down.
    const EntityPose level = pose(47.5, 8.5, 1400, 0, 0, 0);
    EXPECT_TRUE(near(level.position, {0, 0, 1000}, 1e-6))
        << level.position.x << " " << level.position.y << " " << level.position.z;
    EXPECT_TRUE(near(level.forward, {0, 1, 0}, 1e-9));
    EXPECT_TRUE(near(level.up, {0, 0, 1}, 1e-9));
    EXPECT_TRUE(near(pose(47.5, 8.5, 1400, 90, 0, 0).forward, {1, 0, 0}, 1e-6));
    const EntityPose climbing = pose(47.5, 8.5, 1400, 0, 30, 0);
    EXPECT_TRUE(near(climbing.forward, {0, c30, s30}, 1e-6));
    EXPECT_TRUE(near(climbing.up, {0, -s30, c30}, 1e-6));
    const EntityPose rolled = pose(47.5, 8.5, 1400, 0, 0, 30);
    EXPECT_TRUE(near(rolled.forward, {0, 1, 0}, 1e-6));
    EXPECT_TRUE(near(rolled.up, {s30, 0, c30}, 1e-6));  // the top leans towards the right wing (east)
    // 0.1 degree north (11.1 km): level there is 0.1 degree nose down in the origin's axes.
    const EntityPose north = pose(47.6, 8.5, 400, 0, 0, 0);
    EXPECT_NEAR(north.position.y, 11120, 15);
    EXPECT_NEAR(north.forward.z, -std::sin(0.1 * 3.14159265358979323846 / 180), 2e-5);
    // The box drawn for another entity: its length along the nose, its height along the top.
    const nephele::Object box = entityBox(climbing);
    const glm::dmat3 r = nephele::rotationFromDegrees(box.rotationDeg);
    EXPECT_TRUE(near(r * nephele::Vec3(0, 1, 0), climbing.forward, 1e-9));
    EXPECT_TRUE(near(r * nephele::Vec3(0, 0, 1), climbing.up, 1e-9));
    EXPECT_EQ(box.center, climbing.position);
    EXPECT_THROW(pose(91, 0, 0, 0, 0, 0), std::invalid_argument);
    EXPECT_THROW(pose(0, 0, 0, std::numeric_limits<float>::quiet_NaN(), 0, 0), std::invalid_argument);
}
