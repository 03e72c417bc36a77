#include "nephele/cigi.hpp"

#include "nephele/log.hpp"

#include <bit>
#include <type_traits>
#include <string>

namespace nephele::cigi {

namespace {

// Each packet's fields are listed once, by byte offset, in a function template that both the
// reader and the writer walk (docs/cigi.md has the same offsets as tables, with their sources).
// Offsets count from the packet's first byte (its opcode); bit 0 is a byte's least significant.

class Reader {
public:
    Reader(std::span<const std::uint8_t> packet, ByteOrder order) : p_(packet), order_(order) {}

    void u8(std::size_t at, std::uint8_t& v) const { v = byte(at); }
    void i8(std::size_t at, std::int8_t& v) const { v = static_cast<std::int8_t>(byte(at)); }
    void u16(std::size_t at, std::uint16_t& v) const { v = static_cast<std::uint16_t>(word(at, 2)); }
    void u32(std::size_t at, std::uint32_t& v) const { v = static_cast<std::uint32_t>(word(at, 4)); }
    void f32(std::size_t at, float& v) const { v = std::bit_cast<float>(static_cast<std::uint32_t>(word(at, 4))); }
    void f64(std::size_t at, double& v) const { v = std::bit_cast<double>(word(at, 8)); }
    template <class T>
    void bits(std::size_t at, int shift, int width, T& v) const {
        v = static_cast<T>((byte(at) >> shift) & ((1u << width) - 1u));
    }
    void flag(std::size_t at, int shift, bool& v) const { v = ((byte(at) >> shift) & 1u) != 0; }

private:
    // Offsets are the codec's constants and the packet's size was checked against the standard's,
    // so an offset past the packet is a bug of this file: it reads as 0, never past the buffer.
    std::uint8_t byte(std::size_t at) const { return at < p_.size() ? p_[at] : 0; }
    std::uint64_t word(std::size_t at, int n) const {
        std::uint64_t v = 0;
        for (int i = 0; i < n; ++i) {
            const int k = order_ == ByteOrder::BigEndian ? i : n - 1 - i;
            v = (v << 8) | byte(at + static_cast<std::size_t>(k));
        }
        return v;
    }
    std::span<const std::uint8_t> p_;
    ByteOrder order_;
};

class Writer {
public:
    Writer(std::span<std::uint8_t> packet, ByteOrder order) : p_(packet), order_(order) {}

    void u8(std::size_t at, std::uint8_t v) { set(at, v); }
    void i8(std::size_t at, std::int8_t v) { set(at, static_cast<std::uint8_t>(v)); }
    void u16(std::size_t at, std::uint16_t v) { word(at, 2, v); }
    void u32(std::size_t at, std::uint32_t v) { word(at, 4, v); }
    void f32(std::size_t at, float v) { word(at, 4, std::bit_cast<std::uint32_t>(v)); }
    void f64(std::size_t at, double v) { word(at, 8, std::bit_cast<std::uint64_t>(v)); }
    template <class T>
    void bits(std::size_t at, int shift, int width, T v) {
        const unsigned mask = (1u << width) - 1u;
        set(at, static_cast<std::uint8_t>(get(at) | ((static_cast<unsigned>(v) & mask) << shift)));
    }
    void flag(std::size_t at, int shift, bool v) { bits(at, shift, 1, v ? 1u : 0u); }

private:
    std::uint8_t get(std::size_t at) const { return at < p_.size() ? p_[at] : 0; }
    void set(std::size_t at, std::uint8_t v) {
        if (at < p_.size()) p_[at] = v;
    }
    void word(std::size_t at, int n, std::uint64_t v) {
        for (int i = 0; i < n; ++i) {
            const int k = order_ == ByteOrder::BigEndian ? n - 1 - i : i;
            set(at + static_cast<std::size_t>(k), static_cast<std::uint8_t>(v >> (8 * i)));
        }
    }
    std::span<std::uint8_t> p_;
    ByteOrder order_;
};

// Bytes 0 and 1 (opcode, size) are the framing's; bytes 6-7 of IG Control and Start of Frame
// (the byte-swap magic) are written and checked apart.

template <class IO, class P>
void igControlFields(IO& io, P& p) {
    io.u8(2, p.majorVersion);
    io.i8(3, p.databaseNumber);
    io.bits(4, 0, 2, p.igMode);
    io.flag(4, 2, p.timestampValid);
    io.flag(4, 3, p.extrapolationEnable);
    io.bits(4, 4, 4, p.minorVersion);
    io.u32(8, p.hostFrameNumber);
    io.u32(12, p.timestamp);
    io.u32(16, p.lastIgFrameNumber);
}

template <class IO, class P>
void entityControlFields(IO& io, P& p) {
    io.u16(2, p.entityId);
    io.bits(4, 0, 2, p.entityState);
    io.flag(4, 2, p.attached);
    io.flag(4, 3, p.collisionDetectionEnable);
    io.flag(4, 4, p.inheritAlpha);
    io.bits(4, 5, 2, p.groundClamp);
    io.bits(5, 0, 1, p.animationDirection);
    io.bits(5, 1, 1, p.animationLoopMode);
    io.bits(5, 2, 2, p.animationState);
    io.flag(5, 4, p.extrapolationEnable);
    io.u8(6, p.alpha);
    io.u16(8, p.entityType);
    io.u16(10, p.parentId);
    io.f32(12, p.roll);
    io.f32(16, p.pitch);
    io.f32(20, p.yaw);
    io.f64(24, p.latitude);
    io.f64(32, p.longitude);
    io.f64(40, p.altitude);
}

template <class IO, class P>
void viewControlFields(IO& io, P& p) {
    io.u16(2, p.viewId);
    io.u8(4, p.groupId);
    io.flag(5, 0, p.xOffsetEnable);
    io.flag(5, 1, p.yOffsetEnable);
    io.flag(5, 2, p.zOffsetEnable);
    io.flag(5, 3, p.rollEnable);
    io.flag(5, 4, p.pitchEnable);
    io.flag(5, 5, p.yawEnable);
    io.u16(6, p.entityId);
    io.f32(8, p.xOffset);
    io.f32(12, p.yOffset);
    io.f32(16, p.zOffset);
    io.f32(20, p.roll);
    io.f32(24, p.pitch);
    io.f32(28, p.yaw);
}

template <class IO, class P>
void viewDefinitionFields(IO& io, P& p) {
    io.u16(2, p.viewId);
    io.u8(4, p.groupId);
    io.flag(5, 0, p.nearEnable);
    io.flag(5, 1, p.farEnable);
    io.flag(5, 2, p.leftEnable);
    io.flag(5, 3, p.rightEnable);
    io.flag(5, 4, p.topEnable);
    io.flag(5, 5, p.bottomEnable);
    io.bits(5, 6, 2, p.mirrorMode);
    io.bits(6, 0, 3, p.pixelReplication);
    io.flag(6, 3, p.orthographic);
    io.flag(6, 4, p.reorder);
    io.bits(6, 5, 3, p.viewType);
    io.f32(8, p.nearPlane);
    io.f32(12, p.farPlane);
    io.f32(16, p.left);
    io.f32(20, p.right);
    io.f32(24, p.top);
    io.f32(28, p.bottom);
}

template <class IO, class P>
void celestialFields(IO& io, P& p) {
    io.u8(2, p.hour);
    io.u8(3, p.minute);
    io.flag(4, 0, p.ephemerisModelEnable);
    io.flag(4, 1, p.sunEnable);
    io.flag(4, 2, p.moonEnable);
    io.flag(4, 3, p.starFieldEnable);
    io.flag(4, 4, p.dateTimeValid);
    io.u32(8, p.date);
    io.f32(12, p.starFieldIntensity);
}

template <class IO, class P>
void atmosphereFields(IO& io, P& p) {
    io.flag(2, 0, p.atmosphericModelEnable);
    io.u8(3, p.humidity);
    io.f32(4, p.airTemperature);
    io.f32(8, p.visibilityRange);
    io.f32(12, p.horizontalWindSpeed);
    io.f32(16, p.verticalWindSpeed);
    io.f32(20, p.windDirection);
    io.f32(24, p.barometricPressure);
}

template <class IO, class P>
void weatherControlFields(IO& io, P& p) {
    io.u16(2, p.entityOrRegionId);
    io.u8(4, p.layerId);
    io.u8(5, p.humidity);
    io.flag(6, 0, p.weatherEnable);
    io.flag(6, 1, p.scudEnable);
    io.flag(6, 2, p.randomWindsEnable);
    io.flag(6, 3, p.randomLightningEnable);
    io.bits(6, 4, 4, p.cloudType);
    io.bits(7, 0, 2, p.scope);
    io.bits(7, 2, 3, p.severity);
    io.f32(8, p.airTemperature);
    io.f32(12, p.visibilityRange);
    io.f32(16, p.scudFrequency);
    io.f32(20, p.coverage);
    io.f32(24, p.baseElevation);
    io.f32(28, p.thickness);
    io.f32(32, p.transitionBand);
    io.f32(36, p.horizontalWindSpeed);
    io.f32(40, p.verticalWindSpeed);
    io.f32(44, p.windDirection);
    io.f32(48, p.barometricPressure);
    io.f32(52, p.aerosolConcentration);
}

template <class IO, class P>
void envRequestFields(IO& io, P& p) {
    io.bits(2, 0, 4, p.requestType);
    io.u8(3, p.requestId);
    io.f64(8, p.latitude);
    io.f64(16, p.longitude);
    io.f64(24, p.altitude);
}

template <class IO, class P>
void startOfFrameFields(IO& io, P& p) {
    io.u8(2, p.majorVersion);
    io.i8(3, p.databaseNumber);
    io.u8(4, p.igStatus);
    io.bits(5, 0, 2, p.igMode);
    io.flag(5, 2, p.timestampValid);
    io.bits(5, 3, 1, p.earthReferenceModel);
    io.bits(5, 4, 4, p.minorVersion);
    io.u32(8, p.igFrameNumber);
    io.u32(12, p.timestamp);
    io.u32(16, p.lastHostFrameNumber);
}

template <class IO, class P>
void weatherResponseFields(IO& io, P& p) {
    io.u8(2, p.requestId);
    io.u8(3, p.humidity);
    io.f32(4, p.airTemperature);
    io.f32(8, p.visibilityRange);
    io.f32(12, p.horizontalWindSpeed);
    io.f32(16, p.verticalWindSpeed);
    io.f32(20, p.windDirection);
    io.f32(24, p.barometricPressure);
}

template <class IO, class P>
void aerosolResponseFields(IO& io, P& p) {
    io.u8(2, p.requestId);
    io.u8(3, p.layerId);
    io.f32(4, p.aerosolConcentration);
}

// The traits tie a struct to its opcode, size and field list.
template <class P>
struct Traits;
#define NEPHELE_CIGI_TRAITS(Type, fn)                    \
    template <>                                          \
    struct Traits<Type> {                                \
        static constexpr std::uint8_t op = opcode::Type; \
        template <class IO, class Q>                     \
        static void fields(IO& io, Q& p) {               \
            fn(io, p);                                   \
        }                                                \
    };
NEPHELE_CIGI_TRAITS(IgControl, igControlFields)
NEPHELE_CIGI_TRAITS(EntityControl, entityControlFields)
NEPHELE_CIGI_TRAITS(ViewControl, viewControlFields)
NEPHELE_CIGI_TRAITS(ViewDefinition, viewDefinitionFields)
NEPHELE_CIGI_TRAITS(CelestialSphereControl, celestialFields)
NEPHELE_CIGI_TRAITS(AtmosphereControl, atmosphereFields)
NEPHELE_CIGI_TRAITS(WeatherControl, weatherControlFields)
NEPHELE_CIGI_TRAITS(EnvironmentalConditionsRequest, envRequestFields)
NEPHELE_CIGI_TRAITS(StartOfFrame, startOfFrameFields)
NEPHELE_CIGI_TRAITS(WeatherConditionsResponse, weatherResponseFields)
NEPHELE_CIGI_TRAITS(AerosolConcentrationResponse, aerosolResponseFields)
#undef NEPHELE_CIGI_TRAITS

template <class P>
P decode(std::span<const std::uint8_t> packet, ByteOrder order) {
    P p{};
    Reader r(packet, order);
    Traits<P>::fields(r, p);
    return p;
}

template <class P>
void encode(std::vector<std::uint8_t>& out, P p, ByteOrder order) {
    const std::size_t size = packetSize(Traits<P>::op);
    const std::size_t start = out.size();
    out.resize(start + size, 0);  // reserved bytes and bits stay 0, as the standard asks
    std::span<std::uint8_t> packet(out.data() + start, size);
    packet[0] = Traits<P>::op;
    packet[1] = static_cast<std::uint8_t>(size);
    Writer w(packet, order);
    Traits<P>::fields(w, p);
    if constexpr (std::is_same_v<P, IgControl> || std::is_same_v<P, StartOfFrame>) w.u16(6, kByteSwapMagic);
}

void warn(const std::string& message) { logMessage(LogLevel::Warning, "CIGI: " + message); }

const char* name(std::uint8_t op) {
    switch (op) {
        case opcode::IgControl: return "IG Control";
        case opcode::EntityControl: return "Entity Control";
        case opcode::CelestialSphereControl: return "Celestial Sphere Control";
        case opcode::AtmosphereControl: return "Atmosphere Control";
        case opcode::WeatherControl: return "Weather Control";
        case opcode::ViewControl: return "View Control";
        case opcode::ViewDefinition: return "View Definition";
        case opcode::EnvironmentalConditionsRequest: return "Environmental Conditions Request";
        case opcode::StartOfFrame: return "Start of Frame";
        case opcode::WeatherConditionsResponse: return "Weather Conditions Response";
        case opcode::AerosolConcentrationResponse: return "Aerosol Concentration Response";
        default: return "unknown";
    }
}

// The first packet: its opcode and size, major version and byte-swap magic. Returns the byte
// order, or nothing (logged) when the datagram must be dropped.
std::optional<ByteOrder> checkFirst(std::span<const std::uint8_t> bytes, std::uint8_t op, const char* side) {
    const std::size_t size = packetSize(op);
    if (bytes.size() < size) {
        warn(std::string(side) + " datagram of " + std::to_string(bytes.size()) +
             " bytes dropped: shorter than its first packet, " + name(op) + " (" + std::to_string(size) + " bytes)");
        return std::nullopt;
    }
    if (bytes[0] != op) {
        warn(std::string(side) + " datagram dropped: its first packet has opcode " + std::to_string(bytes[0]) +
             ", not " + name(op) + " (" + std::to_string(op) + ") as the standard requires");
        return std::nullopt;
    }
    if (bytes[1] != size) {
        warn(std::string(side) + " datagram dropped: its " + name(op) + " declares " + std::to_string(bytes[1]) +
             " bytes; CIGI 3.3 has " + std::to_string(size));
        return std::nullopt;
    }
    if (bytes[2] != kMajorVersion) {
        warn(std::string(side) + " datagram dropped: CIGI major version " + std::to_string(bytes[2]) +
             ", this IG speaks 3");
        return std::nullopt;
    }
    const unsigned magic = (unsigned(bytes[6]) << 8) | bytes[7];
    if (magic == kByteSwapMagic) return ByteOrder::BigEndian;
    if (magic == 0x0080u) return ByteOrder::LittleEndian;
    warn(std::string(side) + " datagram dropped: byte-swap magic number " + std::to_string(magic) +
         " is neither 0x8000 (big-endian sender) nor 0x0080 (little-endian sender)");
    return std::nullopt;
}

// Walks the packets after the first. `known(op, packet)` decodes a known packet and returns true,
// or returns false for an opcode this side does not accept (skipped).
template <class Datagram, class Known>
void walk(std::span<const std::uint8_t> bytes, std::size_t offset, const char* side, Datagram& d, Known known) {
    while (offset < bytes.size()) {
        const std::size_t left = bytes.size() - offset;
        if (left < 2) {
            warn(std::string(side) + " datagram: " + std::to_string(left) + " byte left at offset " +
                 std::to_string(offset) + ", too few for a packet header; the rest is ignored");
            d.complete = false;
            return;
        }
        const std::uint8_t op = bytes[offset];
        const std::size_t size = bytes[offset + 1];
        if (size < 2) {
            warn(std::string(side) + " datagram: packet at offset " + std::to_string(offset) + " (opcode " +
                 std::to_string(op) + ") declares a size of " + std::to_string(size) + " bytes; the rest is ignored");
            d.complete = false;
            return;
        }
        if (size > left) {
            warn(std::string(side) + " datagram: packet at offset " + std::to_string(offset) + " (" + name(op) +
                 ", opcode " + std::to_string(op) + ") declares " + std::to_string(size) + " bytes but only " +
                 std::to_string(left) + " remain; the rest is ignored");
            d.complete = false;
            return;
        }
        const std::span<const std::uint8_t> packet = bytes.subspan(offset, size);
        const std::size_t expected = packetSize(op);
        if (expected != 0 && size != expected) {
            warn(std::string(side) + " datagram: " + name(op) + " at offset " + std::to_string(offset) + " declares " +
                 std::to_string(size) + " bytes; CIGI 3.3 has " + std::to_string(expected) + ": skipped");
            ++d.skipped;
        } else if (!known(op, packet)) {
            if (expected == 0)
                logMessage(LogLevel::Debug, std::string("CIGI: ") + side + " datagram: opcode " + std::to_string(op) +
                                                " (" + std::to_string(size) + " bytes) is not handled: skipped");
            else
                warn(std::string(side) + " datagram: " + name(op) + " at offset " + std::to_string(offset) +
                     " does not belong here: skipped");
            ++d.skipped;
        }
        offset += size;
    }
}

}  // namespace

std::size_t packetSize(std::uint8_t op) {
    switch (op) {
        case opcode::IgControl: return 24;
        case opcode::EntityControl: return 48;
        case opcode::CelestialSphereControl: return 16;
        case opcode::AtmosphereControl: return 32;
        case opcode::WeatherControl: return 56;
        case opcode::ViewControl: return 32;
        case opcode::ViewDefinition: return 32;
        case opcode::EnvironmentalConditionsRequest: return 32;
        case opcode::StartOfFrame: return 24;
        case opcode::WeatherConditionsResponse: return 32;
        case opcode::AerosolConcentrationResponse: return 8;
        default: return 0;
    }
}

std::optional<HostDatagram> parseHostDatagram(std::span<const std::uint8_t> bytes) {
    const std::optional<ByteOrder> order = checkFirst(bytes, opcode::IgControl, "host");
    if (!order) return std::nullopt;
    HostDatagram d;
    d.byteOrder = *order;
    d.igControl = decode<IgControl>(bytes.first(packetSize(opcode::IgControl)), *order);
    walk(bytes, packetSize(opcode::IgControl), "host", d, [&](std::uint8_t op, std::span<const std::uint8_t> p) {
        switch (op) {
            case opcode::EntityControl: d.packets.emplace_back(decode<EntityControl>(p, *order)); return true;
            case opcode::ViewControl: d.packets.emplace_back(decode<ViewControl>(p, *order)); return true;
            case opcode::ViewDefinition: d.packets.emplace_back(decode<ViewDefinition>(p, *order)); return true;
            case opcode::CelestialSphereControl:
                d.packets.emplace_back(decode<CelestialSphereControl>(p, *order));
                return true;
            case opcode::AtmosphereControl: d.packets.emplace_back(decode<AtmosphereControl>(p, *order)); return true;
            case opcode::WeatherControl: d.packets.emplace_back(decode<WeatherControl>(p, *order)); return true;
            case opcode::EnvironmentalConditionsRequest:
                d.packets.emplace_back(decode<EnvironmentalConditionsRequest>(p, *order));
                return true;
            default: return false;  // a second IG Control, an IG's packet, or an opcode not handled
        }
    });
    return d;
}

std::optional<IgDatagram> parseIgDatagram(std::span<const std::uint8_t> bytes) {
    const std::optional<ByteOrder> order = checkFirst(bytes, opcode::StartOfFrame, "IG");
    if (!order) return std::nullopt;
    IgDatagram d;
    d.byteOrder = *order;
    d.startOfFrame = decode<StartOfFrame>(bytes.first(packetSize(opcode::StartOfFrame)), *order);
    walk(bytes, packetSize(opcode::StartOfFrame), "IG", d, [&](std::uint8_t op, std::span<const std::uint8_t> p) {
        switch (op) {
            case opcode::WeatherConditionsResponse:
                d.packets.emplace_back(decode<WeatherConditionsResponse>(p, *order));
                return true;
            case opcode::AerosolConcentrationResponse:
                d.packets.emplace_back(decode<AerosolConcentrationResponse>(p, *order));
                return true;
            default: return false;
        }
    });
    return d;
}

void DatagramWriter::add(const IgControl& p) { encode(bytes_, p, order_); }
void DatagramWriter::add(const EntityControl& p) { encode(bytes_, p, order_); }
void DatagramWriter::add(const ViewControl& p) { encode(bytes_, p, order_); }
void DatagramWriter::add(const ViewDefinition& p) { encode(bytes_, p, order_); }
void DatagramWriter::add(const CelestialSphereControl& p) { encode(bytes_, p, order_); }
void DatagramWriter::add(const AtmosphereControl& p) { encode(bytes_, p, order_); }
void DatagramWriter::add(const WeatherControl& p) { encode(bytes_, p, order_); }
void DatagramWriter::add(const EnvironmentalConditionsRequest& p) { encode(bytes_, p, order_); }
void DatagramWriter::add(const StartOfFrame& p) { encode(bytes_, p, order_); }
void DatagramWriter::add(const WeatherConditionsResponse& p) { encode(bytes_, p, order_); }
void DatagramWriter::add(const AerosolConcentrationResponse& p) { encode(bytes_, p, order_); }
void DatagramWriter::add(const HostPacket& p) {
    std::visit([&](const auto& q) { add(q); }, p);
}
void DatagramWriter::add(const IgPacket& p) {
    std::visit([&](const auto& q) { add(q); }, p);
}

}  // namespace nephele::cigi
