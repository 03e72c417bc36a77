// CIGI 3.3 (SISO-STD-013-2002, Common Image Generator Interface ICD version 3.3): the packets
// `nephele ig` reads from a host and writes back, as plain structs, and the codec that turns a
// UDP datagram into them and them into a datagram. No sockets, no rendering: docs/cigi.md has
// each packet's byte layout, its sources and what Nephele does with each field.
//
// Byte order: a CIGI sender writes every multi-byte field in its own byte order and says which
// through the Byte Swap Magic Number 0x8000 of the datagram's first packet (IG Control from a
// host, Start of Frame from an IG): read as big-endian it is 0x8000 when the sender was
// big-endian and 0x0080 when it was little-endian. The whole datagram then reads in that order.
//
// Malformed input never throws and never reads past the buffer: the parser reports through
// nephele's log callback (nephele/log.hpp), skips what it can skip (an unknown opcode, a known
// opcode with the wrong size) and stops at what breaks the framing (a size byte under 2 or past
// the end of the datagram), keeping the packets before it.
#pragma once

#include "nephele/api.hpp"
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <variant>
#include <vector>

NEPHELE_API_BEGIN
namespace nephele::cigi {

enum class ByteOrder : std::uint8_t { BigEndian, LittleEndian };

inline constexpr std::uint16_t kByteSwapMagic = 0x8000;
inline constexpr std::uint8_t kMajorVersion = 3;
inline constexpr std::uint8_t kMinorVersion = 3;  // CIGI 3.3 (3.2 is minor version 2)

// Opcodes (Packet ID) and sizes (Packet Size, bytes) of the packets this codec knows.
namespace opcode {
inline constexpr std::uint8_t IgControl = 1;
inline constexpr std::uint8_t EntityControl = 2;
inline constexpr std::uint8_t CelestialSphereControl = 9;
inline constexpr std::uint8_t AtmosphereControl = 10;
inline constexpr std::uint8_t WeatherControl = 12;
inline constexpr std::uint8_t ViewControl = 16;
inline constexpr std::uint8_t ViewDefinition = 21;
inline constexpr std::uint8_t EnvironmentalConditionsRequest = 28;
inline constexpr std::uint8_t StartOfFrame = 101;
inline constexpr std::uint8_t WeatherConditionsResponse = 109;
inline constexpr std::uint8_t AerosolConcentrationResponse = 110;
}  // namespace opcode

// The standard's size of a known opcode's packet; 0 for an opcode this codec does not know.
std::size_t packetSize(std::uint8_t opcode);

enum class IgMode : std::uint8_t { Reset = 0, Operate = 1, Debug = 2, OfflineMaintenance = 3 };

// Host -> IG ---------------------------------------------------------------------------------

// IG Control (opcode 1, 24 bytes): the first packet of every host datagram, one per host frame.
struct IgControl {
    std::uint8_t majorVersion = kMajorVersion;
    std::uint8_t minorVersion = kMinorVersion;
    std::int8_t databaseNumber = 0;  // 0: no change; > 0 load that database; < 0 (IG -> host only)
    IgMode igMode = IgMode::Operate;
    bool timestampValid = false;
    bool extrapolationEnable = false;  // the ICD's Extrapolation/Interpolation Enable
    std::uint32_t hostFrameNumber = 0;
    std::uint32_t timestamp = 0;          // 10 microsecond ticks
    std::uint32_t lastIgFrameNumber = 0;  // the IG frame number of the last Start of Frame the host read

    bool operator==(const IgControl&) const = default;
};

// Entity Control (opcode 2, 48 bytes): an entity's place and attitude (geodetic for a top-level
// entity, metres in the parent's body frame for a child).
struct EntityControl {
    std::uint16_t entityId = 0;    // 0 is the ownship
    std::uint8_t entityState = 0;  // 0 inactive/standby, 1 active, 2 destroyed
    bool attached = false;         // Attach State: positioned relative to parentId
    bool collisionDetectionEnable = false;
    bool inheritAlpha = false;
    std::uint8_t groundClamp = 0;         // 0 none, 1 non-conformal, 2 conformal
    std::uint8_t animationDirection = 0;  // 0 forward, 1 backward
    std::uint8_t animationLoopMode = 0;   // 0 one-shot, 1 continuous
    std::uint8_t animationState = 0;      // 0 stop, 1 pause, 2 play, 3 continue
    bool extrapolationEnable = false;
    std::uint8_t alpha = 255;
    std::uint16_t entityType = 0;
    std::uint16_t parentId = 0;
    float roll = 0, pitch = 0, yaw = 0;  // degrees
    double latitude = 0;                 // degrees, or x offset (m) from the parent
    double longitude = 0;                // degrees, or y offset (m)
    double altitude = 0;                 // m above mean sea level, or z offset (m)

    bool operator==(const EntityControl&) const = default;
};

// View Control (opcode 16, 32 bytes): a view's (or view group's) eyepoint relative to an entity.
struct ViewControl {
    std::uint16_t viewId = 0;
    std::uint8_t groupId = 0;  // 0: none
    bool xOffsetEnable = false, yOffsetEnable = false, zOffsetEnable = false;
    bool rollEnable = false, pitchEnable = false, yawEnable = false;
    std::uint16_t entityId = 0;
    float xOffset = 0, yOffset = 0, zOffset = 0;  // m, entity body frame
    float roll = 0, pitch = 0, yaw = 0;           // degrees

    bool operator==(const ViewControl&) const = default;
};

// View Definition (opcode 21, 32 bytes): a view's frustum as half-angles.
struct ViewDefinition {
    std::uint16_t viewId = 0;
    std::uint8_t groupId = 0;
    bool nearEnable = false, farEnable = false, leftEnable = false;
    bool rightEnable = false, topEnable = false, bottomEnable = false;
    std::uint8_t mirrorMode = 0;                     // 0 none, 1 horizontal, 2 vertical, 3 both
    std::uint8_t pixelReplication = 0;               // 0 none, 1 1x2, 2 2x1, 3 2x2
    bool orthographic = false;                       // Projection Type: 0 perspective, 1 orthographic
    bool reorder = false;                            // bring this view to the top
    std::uint8_t viewType = 0;                       // IG-defined
    float nearPlane = 0, farPlane = 0;               // m
    float left = 0, right = 0, top = 0, bottom = 0;  // degrees from the view's axis; left, bottom negative

    bool operator==(const ViewDefinition&) const = default;
};

// Celestial Sphere Control (opcode 9, 16 bytes): time of day and date.
struct CelestialSphereControl {
    std::uint8_t hour = 0, minute = 0;  // UTC
    bool ephemerisModelEnable = false;
    bool sunEnable = false, moonEnable = false, starFieldEnable = false;
    bool dateTimeValid = false;
    std::uint32_t date = 0;        // MMDDYYYY as a decimal number (June 21, 2026: 6212026)
    float starFieldIntensity = 0;  // percent

    bool operator==(const CelestialSphereControl&) const = default;
};

// Atmosphere Control (opcode 10, 32 bytes): the global atmosphere.
struct AtmosphereControl {
    bool atmosphericModelEnable = false;
    std::uint8_t humidity = 0;                             // percent
    float airTemperature = 0;                              // degrees C
    float visibilityRange = 0;                             // m
    float horizontalWindSpeed = 0, verticalWindSpeed = 0;  // m/s
    float windDirection = 0;                               // degrees from true north, where the wind blows from
    float barometricPressure = 0;                          // mb (hPa)

    bool operator==(const AtmosphereControl&) const = default;
};

// Weather Control (opcode 12, 56 bytes): one weather layer (or a region's or entity's weather).
struct WeatherControl {
    std::uint16_t entityOrRegionId = 0;  // Entity ID (scope 2) or Region ID (scope 1)
    std::uint8_t layerId = 0;            // 0 ground fog, 1..3 cloud layers, 4..9 rain..dust, 10..255 IG-defined
    std::uint8_t humidity = 0;           // percent
    bool weatherEnable = false, scudEnable = false, randomWindsEnable = false, randomLightningEnable = false;
    std::uint8_t cloudType = 0;                            // 0..15 (nephele::CigiCloudType)
    std::uint8_t scope = 0;                                // 0 global, 1 regional, 2 entity
    std::uint8_t severity = 0;                             // 0..5
    float airTemperature = 0;                              // degrees C
    float visibilityRange = 0;                             // m
    float scudFrequency = 0;                               // percent
    float coverage = 0;                                    // percent
    float baseElevation = 0;                               // m above mean sea level
    float thickness = 0;                                   // m
    float transitionBand = 0;                              // m
    float horizontalWindSpeed = 0, verticalWindSpeed = 0;  // m/s
    float windDirection = 0;                               // degrees from true north, where the wind blows from
    float barometricPressure = 0;                          // mb (hPa)
    float aerosolConcentration = 0;                        // g/m^3

    bool operator==(const WeatherControl&) const = default;
};

// Environmental Conditions Request (opcode 28, 32 bytes): asks for the conditions at a point.
struct EnvironmentalConditionsRequest {
    // Request Type bits: 1 maritime surface, 2 terrestrial surface, 4 weather, 8 aerosol.
    std::uint8_t requestType = 0;
    std::uint8_t requestId = 0;
    double latitude = 0, longitude = 0;  // degrees
    double altitude = 0;                 // m

    bool operator==(const EnvironmentalConditionsRequest&) const = default;
};

// IG -> host ---------------------------------------------------------------------------------

// Start of Frame (opcode 101, 24 bytes): the first packet of every IG datagram.
struct StartOfFrame {
    std::uint8_t majorVersion = kMajorVersion;
    std::uint8_t minorVersion = kMinorVersion;
    std::int8_t databaseNumber = 0;
    std::uint8_t igStatus = 0;  // 0: normal; otherwise an IG-defined error code
    IgMode igMode = IgMode::Operate;
    bool timestampValid = false;
    std::uint8_t earthReferenceModel = 0;  // 0 WGS 84, 1 host-defined
    std::uint32_t igFrameNumber = 0;
    std::uint32_t timestamp = 0;  // 10 microsecond ticks
    std::uint32_t lastHostFrameNumber = 0;

    bool operator==(const StartOfFrame&) const = default;
};

// Weather Conditions Response (opcode 109, 32 bytes).
struct WeatherConditionsResponse {
    std::uint8_t requestId = 0;
    std::uint8_t humidity = 0;                             // percent
    float airTemperature = 0;                              // degrees C
    float visibilityRange = 0;                             // m
    float horizontalWindSpeed = 0, verticalWindSpeed = 0;  // m/s
    float windDirection = 0;                               // degrees
    float barometricPressure = 0;                          // mb

    bool operator==(const WeatherConditionsResponse&) const = default;
};

// Aerosol Concentration Response (opcode 110, 8 bytes): one per weather layer at the point.
struct AerosolConcentrationResponse {
    std::uint8_t requestId = 0;
    std::uint8_t layerId = 0;
    float aerosolConcentration = 0;  // g/m^3

    bool operator==(const AerosolConcentrationResponse&) const = default;
};

// Datagrams -----------------------------------------------------------------------------------

using HostPacket = std::variant<EntityControl, ViewControl, ViewDefinition, CelestialSphereControl, AtmosphereControl,
                                WeatherControl, EnvironmentalConditionsRequest>;
using IgPacket = std::variant<WeatherConditionsResponse, AerosolConcentrationResponse>;

// A host's datagram: its IG Control and the packets after it that this codec knows, in order.
struct HostDatagram {
    ByteOrder byteOrder = ByteOrder::BigEndian;
    IgControl igControl;
    std::vector<HostPacket> packets;
    int skipped = 0;       // unknown opcodes, known opcodes of the wrong size, stray IG/IG->host packets
    bool complete = true;  // false: parsing stopped at a packet that broke the framing
};

struct IgDatagram {
    ByteOrder byteOrder = ByteOrder::BigEndian;
    StartOfFrame startOfFrame;
    std::vector<IgPacket> packets;
    int skipped = 0;
    bool complete = true;
};

// Parses a datagram from a host. Empty (with a logged warning) when the datagram does not start
// with a valid IG Control: too short, another opcode, a size other than 24, a major version
// other than 3 or a byte-swap magic that is neither 0x8000 nor 0x0080.
std::optional<HostDatagram> parseHostDatagram(std::span<const std::uint8_t> bytes);

// The same for a datagram from an IG, which starts with Start of Frame (a host's side, and the
// tests').
std::optional<IgDatagram> parseIgDatagram(std::span<const std::uint8_t> bytes);

// Builds a datagram packet by packet in one byte order. Start a host datagram with IgControl and
// an IG datagram with StartOfFrame: the writer does not check.
class DatagramWriter {
public:
    explicit DatagramWriter(ByteOrder order = ByteOrder::BigEndian) : order_(order) {}

    void add(const IgControl& p);
    void add(const EntityControl& p);
    void add(const ViewControl& p);
    void add(const ViewDefinition& p);
    void add(const CelestialSphereControl& p);
    void add(const AtmosphereControl& p);
    void add(const WeatherControl& p);
    void add(const EnvironmentalConditionsRequest& p);
    void add(const StartOfFrame& p);
    void add(const WeatherConditionsResponse& p);
    void add(const AerosolConcentrationResponse& p);
    void add(const HostPacket& p);
    void add(const IgPacket& p);

    const std::vector<std::uint8_t>& bytes() const { return bytes_; }
    void clear() { bytes_.clear(); }

private:
    ByteOrder order_;
    std::vector<std::uint8_t> bytes_;
};

}  // namespace nephele::cigi
NEPHELE_API_END
