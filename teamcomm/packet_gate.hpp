// What a receiver checks after the MAC: the team id, the send time against our clock, replays
// (the sequence number must grow per sender) and each sender's rate. Plain library: times come
// in as arguments.
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include "common/time/clock.hpp"
#include "teamcomm/packet.hpp"

namespace fieldline::teamcomm {

struct GateOptions {
  std::uint8_t team_id = 0;
  // Sustained packets per second a sender may send, and how many may come back to back.
  double rate_limit_hz = 40.0;
  double burst = 10.0;
  // A packet older than this on arrival (once the sender's clock offset is known) is stale.
  Utime max_age_us = 1'000'000;
  // A packet that claims to be sent this far after its arrival is from the future.
  Utime future_tolerance_us = 100'000;
  // Before an offset is known, the sender's clock may differ from ours by at most this much.
  Utime max_clock_difference_us = 10'000'000;
};

class PacketGate {
 public:
  explicit PacketGate(GateOptions options);

  // Admits or refuses an authenticated packet that arrived at `receive_utime` (our clock).
  // `sender_offset_us` is the sender's clock minus ours when known. An admitted packet moves
  // the sender's sequence number and uses up one of its rate tokens. `fresh_by_echo`: the
  // packet echoes one of our own recent packets, so it was made after that one whatever its
  // stamps say; such a packet far behind the sender's sequence (more than the replay window) is
  // the sender restarted with its clock set back, and its sequence is followed from there
  // (counted in restarts()) instead of refusing it as a replay until the old numbers are passed.
  std::optional<Reject> admit(const TeamPacket& packet, Utime receive_utime,
                              std::optional<double> sender_offset_us, bool fresh_by_echo = false);

  // Whether `sequence` is beyond the newest admitted from `robot_id` (or none was admitted).
  bool newer(int robot_id, std::uint64_t sequence) const;
  // Sequence restarts accepted from `robot_id` (see admit).
  std::int64_t restarts(int robot_id) const;

  // Packets lost between admitted ones from `robot_id` (gaps in the sequence numbers).
  std::int64_t lost(int robot_id) const;

 private:
  struct Sender {
    std::optional<std::uint64_t> last_sequence;
    // Bit k: sequence last_sequence - k was seen (tells a reordered packet from a replay).
    std::uint64_t seen = 0;
    double tokens = 0.0;
    Utime last_refill = 0;
    std::int64_t lost = 0;
    std::int64_t restarts = 0;
  };
  GateOptions options_;
  std::array<Sender, kMaxRobots + 1> senders_{};
};

}  // namespace fieldline::teamcomm
