// Fuzzes every LCM message decoder through the bus's checked decode and validation
// (common/bus/checked_decode.hpp): the first byte picks the channel (and so the type), the rest
// is the encoded message. Anything must come back as accepted or as a named rejection.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "common/bus/channels.hpp"
#include "common/bus/checked_decode.hpp"

namespace bus = fieldline::bus;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0 || size > (1u << 24)) return 0;
  const auto& channel = bus::kAllChannelNames[data[0] % bus::kAllChannelNames.size()];
  // A fixed "now" far in the future of any seed, so the future check runs on both branches.
  constexpr fieldline::Utime kNow = 1'800'000'000'000'000;
  constexpr fieldline::Utime kTolerance = 1'000'000;
  const auto rejection =
      bus::checkEncoded(channel, data + 1, static_cast<int>(size - 1), kNow, kTolerance);
  if (rejection && (rejection->kind.empty() || rejection->text.empty())) std::abort();
  return 0;
}
