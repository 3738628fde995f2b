// Fuzzes the motor controller's streaming frame decoder (common/serial/protocol.hpp): any byte
// stream, fed in pieces whose sizes the input chooses, must decode without a crash, and every
// message that comes out must re-encode into a frame that decodes to the same message.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "common/serial/protocol.hpp"

namespace serial = fieldline::serial;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  // The first byte sets the piece size, so split frames are exercised too.
  const std::size_t piece = 1 + data[0] % 64;
  std::span<const std::uint8_t> rest(data + 1, size - 1);

  serial::Decoder decoder;
  std::vector<serial::Message> messages;
  while (!rest.empty()) {
    const std::size_t n = rest.size() < piece ? rest.size() : piece;
    decoder.feed(rest.first(n), messages);
    rest = rest.subspan(n);
  }
  if (decoder.stats().frames_ok != messages.size()) std::abort();

  for (const auto& message : messages) {
    const std::vector<std::uint8_t> frame = serial::encode(message);
    if (frame.size() > serial::kMaxFrameSize) std::abort();
    serial::Decoder again;
    std::vector<serial::Message> round_trip;
    again.feed(frame, round_trip);
    if (round_trip.size() != 1 || !(round_trip.front() == message)) std::abort();
  }
  return 0;
}
