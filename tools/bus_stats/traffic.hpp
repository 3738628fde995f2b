// The accounting behind fieldline-bus-stats, without a bus (tested in tests/unit/health): each
// packet is checked against the fingerprint of the type its channel carries (the 8 bytes every
// LCM encoding starts with); a packet on an unknown channel, with another type's fingerprint or
// an undecodable header is counted as foreign, never as a message. A packet with the right
// fingerprint is decoded and validated in full as a receiver would: one that does not decode is
// counted as undecodable, one that fails validation (NaN, bad sizes) as invalid, neither as a
// message. Seq gaps are tracked per publisher as every receiver does (common/bus/seq_tracker.hpp);
// latencies outside a plausible window are counted, not averaged in.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/bus/seq_tracker.hpp"
#include "common/time/clock.hpp"

namespace fieldline::bus_stats {

// The fingerprint of the type carried by `channel` (channels.hpp), or nothing for an unknown one.
std::optional<std::int64_t> expectedFingerprint(const std::string& channel);

struct ChannelTraffic {
  std::int64_t count = 0;
  std::int64_t bytes = 0;
  // Packets on this channel name that are not a message of its type (wrong fingerprint,
  // undecodable header, or a channel fieldline does not have).
  std::int64_t foreign = 0;
  // Packets with this channel's fingerprint whose body does not decode (a truncated or forged
  // body), and ones that decode but fail validation (NaN, sizes that disagree).
  std::int64_t undecodable = 0;
  std::int64_t invalid = 0;
  // Messages lost by seq gaps (single-publisher channels only).
  std::int64_t gaps = 0;
  // Sequences that really moved on after a jump too large to be losses, counted once each.
  std::int64_t resyncs = 0;
  // Seqs no real publisher sends (a jump too large for the time, a repeat, a message inside a gap
  // counted before: its drops are taken back).
  std::int64_t suspicious = 0;
  // Messages whose utime_published - utime is outside the plausible window.
  std::int64_t bad_stamps = 0;
  std::vector<float> latency_ms;
  Utime first = 0, last = 0;
  // Seq accounting per (robot_id, publisher_id).
  std::map<std::pair<int, std::int64_t>, bus::SeqTracker> last_seq;
};

class TrafficCounter {
 public:
  static constexpr Utime kMinLatencyUs = -kMicrosPerSecond;
  static constexpr Utime kMaxLatencyUs = 60 * kMicrosPerSecond;
  static constexpr std::size_t kMaxPublishers = 64;

  // One packet received on `bus` at receiver time `now`.
  void onPacket(const std::string& bus, const std::string& channel, const void* data, int size,
                Utime now);
  const std::map<std::pair<std::string, std::string>, ChannelTraffic>& traffic() const {
    return traffic_;
  }
  std::map<std::pair<std::string, std::string>, ChannelTraffic>& traffic() { return traffic_; }

 private:
  std::map<std::pair<std::string, std::string>, ChannelTraffic> traffic_;
};

}  // namespace fieldline::bus_stats
