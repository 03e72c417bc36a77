// libFuzzer target of the CIGI 3.3 codec (cigi/, docs/cigi.md): any bytes, read as a host's
// datagram and as an IG's. Besides the sanitizers' checks, what was read must write back and
// read again to the same bytes (compared as bytes, so that NaN fields compare equal).
#include "nephele/cigi.hpp"
#include "nephele/log.hpp"

#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

using namespace nephele::cigi;

namespace {

template <class Datagram>
std::vector<std::uint8_t> write(const Datagram& d) {
    DatagramWriter w(d.byteOrder);
    if constexpr (std::is_same_v<Datagram, HostDatagram>) w.add(d.igControl);
    else w.add(d.startOfFrame);
    for (const auto& p : d.packets) w.add(p);
    return w.bytes();
}

template <class Parse>
void roundTrip(std::span<const std::uint8_t> bytes, Parse parse) {
    const auto d = parse(bytes);
    if (!d) return;
    const std::vector<std::uint8_t> once = write(*d);
    const auto again = parse(once);
    if (!again || !again->complete || again->skipped != 0 || again->packets.size() != d->packets.size()) std::abort();
    if (write(*again) != once) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const bool quiet = (nephele::setLogCallback({}), true);  // the parser's warnings: not the fuzzer's output
    (void)quiet;
    const std::span<const std::uint8_t> bytes(data, size);
    roundTrip(bytes, [](std::span<const std::uint8_t> b) { return parseHostDatagram(b); });
    roundTrip(bytes, [](std::span<const std::uint8_t> b) { return parseIgDatagram(b); });
    return 0;
}
