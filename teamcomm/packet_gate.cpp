#include "teamcomm/packet_gate.hpp"

#include <algorithm>

namespace fieldline::teamcomm {

PacketGate::PacketGate(GateOptions options) : options_(options) {}

std::optional<Reject> PacketGate::admit(const TeamPacket& packet, Utime receive_utime,
                                        std::optional<double> sender_offset_us,
                                        bool fresh_by_echo) {
  if (packet.team_id != options_.team_id) return Reject::kTeam;
  Sender& s = senders_.at(packet.robot_id);
  // How long ago the packet was sent, in our clock (a bound on the offset before it is known).
  const double age_us =
      static_cast<double>(receive_utime - packet.send_utime) + sender_offset_us.value_or(0.0);
  if (sender_offset_us) {
    if (age_us > static_cast<double>(options_.max_age_us) ||
        age_us < -static_cast<double>(options_.future_tolerance_us)) {
      return Reject::kStale;
    }
  } else if (std::abs(age_us) > static_cast<double>(options_.max_clock_difference_us)) {
    return Reject::kStale;
  }
  if (s.last_sequence && packet.sequence <= *s.last_sequence && fresh_by_echo &&
      *s.last_sequence - packet.sequence >= 64) {
    // A new process of the sender, started on a clock set back: nothing old can echo our packet.
    s.last_sequence.reset();
    s.seen = 0;
    ++s.restarts;
  }
  if (s.last_sequence && packet.sequence <= *s.last_sequence) {
    const std::uint64_t back = *s.last_sequence - packet.sequence;
    if (back >= 64 || (s.seen & (std::uint64_t{1} << back))) return Reject::kReplay;
    // Newer news has arrived already; remember this one so a copy counts as a replay.
    s.seen |= std::uint64_t{1} << back;
    return Reject::kLate;
  }
  // Token bucket on our clock; a clock step backwards refills nothing.
  if (s.last_refill == 0) {
    s.tokens = options_.burst;
  } else if (receive_utime > s.last_refill) {
    s.tokens = std::min(options_.burst,
                        s.tokens + options_.rate_limit_hz *
                                       static_cast<double>(receive_utime - s.last_refill) / 1e6);
  }
  s.last_refill = std::max(s.last_refill, receive_utime);
  if (s.tokens < 1.0) return Reject::kRate;
  s.tokens -= 1.0;
  if (s.last_sequence && packet.sequence - *s.last_sequence < 1000) {
    s.lost += static_cast<std::int64_t>(packet.sequence - *s.last_sequence - 1);
  }
  if (s.last_sequence) {
    const std::uint64_t ahead = packet.sequence - *s.last_sequence;
    s.seen = ahead >= 64 ? 0 : s.seen << ahead;
  }
  s.seen |= 1;
  s.last_sequence = packet.sequence;
  return std::nullopt;
}

bool PacketGate::newer(int robot_id, std::uint64_t sequence) const {
  if (robot_id < 1 || robot_id > kMaxRobots) return false;
  const Sender& s = senders_[static_cast<std::size_t>(robot_id)];
  return !s.last_sequence || sequence > *s.last_sequence;
}

std::int64_t PacketGate::restarts(int robot_id) const {
  if (robot_id < 1 || robot_id > kMaxRobots) return 0;
  return senders_[static_cast<std::size_t>(robot_id)].restarts;
}

std::int64_t PacketGate::lost(int robot_id) const {
  if (robot_id < 1 || robot_id > kMaxRobots) return 0;
  return senders_[static_cast<std::size_t>(robot_id)].lost;
}

}  // namespace fieldline::teamcomm
