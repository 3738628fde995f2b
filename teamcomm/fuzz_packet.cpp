// libFuzzer target for the team packet decoder, built with clang, AddressSanitizer and
// UndefinedBehaviorSanitizer (teamcomm/CMakeLists.txt). Half the inputs are decoded as they come
// (the MAC stops nearly all); the other half get the magic, the version and a valid MAC around
// them, so the layout and range checks behind the MAC are fuzzed too. Whatever decodes must
// encode back to the same bytes and pass through the gate without trouble.
#include <sodium.h>

#include <cstdint>
#include <cstdlib>
#include <vector>

#include "teamcomm/packet.hpp"
#include "teamcomm/packet_gate.hpp"

using namespace fieldline::teamcomm;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const TeamKey key = [] {
    TeamKey k;
    for (std::size_t i = 0; i < k.bytes.size(); ++i)
      k.bytes[i] = static_cast<std::uint8_t>(i);
    return k;
  }();
  if (size == 0) return 0;
  std::vector<std::uint8_t> bytes;
  if (data[0] & 1) {
    // A signed packet: magic and version in place, the fuzzer's bytes as the rest of the body.
    bytes = {'F', 'L', 'T', 'M', kProtocolVersion};
  }
  bytes.insert(bytes.end(), data + 1, data + size);
  if (data[0] & 1) {
    if (sodium_init() < 0) std::abort();
    const std::size_t body = bytes.size();
    bytes.resize(body + kMacBytes);
    crypto_auth(bytes.data() + body, bytes.data(), body, key.bytes.data());
  }
  const DecodeResult r = decodePacket(bytes, key);
  if (!r.packet) return 0;
  if (encodePacket(*r.packet, key) != bytes) std::abort();
  PacketGate gate({.team_id = r.packet->team_id});
  (void)gate.admit(*r.packet, r.packet->send_utime, 0.0);
  return 0;
}
