// Per-process traffic and health statistics behind SERVICE_STATUS: counts and rates per channel,
// drops from seq gaps, latency and processing-time percentiles, error counters, metrics.
// Plain C++ (the Node feeds it), so it is tested without a bus.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <fieldline/service_status_t.hpp>

#include "common/bus/seq_tracker.hpp"
#include "common/time/clock.hpp"

namespace fieldline::bus {

enum class Direction : std::int8_t { kIn = 0, kOut = 1 };

// One publisher of a channel as the receiver sees it: a (robot_id, publisher_id) pair.
struct PublisherTrack {
  int robot_id = 0;
  std::int64_t publisher_id = 0;
  SeqTracker seq;
  // Receiver's clock when its last message arrived.
  Utime last_seen = 0;
};

struct ChannelStats {
  std::string name;
  Direction direction = Direction::kIn;
  std::int64_t total = 0;
  std::int64_t in_period = 0;
  std::int64_t drops = 0;
  // A sequence that really moved on after a jump too large to be losses: counted once each.
  std::int64_t resyncs = 0;
  // Seqs no real publisher sends (seq_tracker.hpp): a jump too large for the time between two
  // messages, a repeat, a message inside a gap counted before (those drops are taken back).
  std::int64_t suspicious = 0;
  // Receiver's clock of the last suspicious seq (-1: never) and what it was.
  Utime suspicious_seen = -1;
  std::string suspicious_text;
  std::int64_t rejected = 0;
  std::vector<float> latency_ms;  // this period's samples
  // Bounded (StatusCollector::kMaxPublishersPerChannel), least recently seen evicted.
  std::vector<PublisherTrack> publishers;
  // Receiver's clock at each change of publisher between consecutive messages, recent only.
  std::vector<Utime> publisher_switches;
  // Per robot id, the publisher of its previous message: a channel with one publisher by design
  // has one per robot (a viewer hears six robots' VISION_LINES, one publisher each).
  std::vector<PublisherTrack> last_publisher_by_robot;
  // Receiver's clock when a second concurrent publisher was last detected; -1: never.
  Utime conflict_seen = -1;
  std::string conflict_text;
  // Receiver's clock of the last message; -1: none yet.
  Utime last_message = -1;
  // Liveness: the rate this process needs (0: not required) and since when it is below it.
  double required_rate_hz = 0;
  Utime below_since = -1;
};

struct Percentiles {
  float p50 = 0, p95 = 0, max = 0;
};
// Percentiles of `samples` (reorders them). Zeros when empty.
Percentiles percentiles(std::vector<float>& samples);

// What a receiver knows about one received message, for the statistics.
struct Received {
  int robot_id = 0;
  std::int64_t publisher_id = 0;
  std::int64_t seq = 0;
  Utime utime = 0;
  Utime utime_published = 0;
};

class StatusCollector {
 public:
  static constexpr std::size_t kMaxPublishersPerChannel = 16;
  // Publisher changes between consecutive messages within kConflictWindowUs that mean two
  // processes publish at once (a restart makes one change).
  static constexpr std::size_t kConflictSwitches = 3;
  static constexpr Utime kConflictWindowUs = 2 * kMicrosPerSecond;
  // A suspicious seq keeps the state at WARN (naming the channel and publisher) this long.
  static constexpr Utime kSuspiciousHoldUs = 10 * kMicrosPerSecond;

  StatusCollector(std::string process, int robot_id, Utime start);

  // A received message at receiver time `now`: counts it, tracks seq gaps per publisher,
  // records the sender's latency. With `single_publisher`, a second publisher on the channel
  // at the same time puts the process into STATE_ERROR naming both.
  void onReceived(const std::string& channel, const Received& message, Utime now,
                  bool single_publisher);
  // The place of a channel's statistics in one direction, made on first use as every function
  // here makes it: a caller that keeps it counts each message by it (onReceivedAt,
  // onPublishedAt) without looking the channel up by name (bus::Node, issue 32).
  int slot(std::string_view channel, Direction d);
  void onReceivedAt(int slot, const Received& message, Utime now, bool single_publisher);
  // Declares that the process needs `channel` (an input, or an output for a flow the process
  // produces from a device) at `min_rate_hz` or more; below it for longer than `grace_us` the
  // state is STATE_WARN with the reason.
  void requireRate(const std::string& channel, Direction d, double min_rate_hz);
  void setRateGrace(Utime grace_us) { rate_grace_us_ = grace_us; }

  // As above for a sender without publisher id, at its own publish time.
  // `track_drops` is false on channels with several publishers per robot (SERVICE_STATUS).
  void onReceived(const std::string& channel, int sender, std::int64_t seq, Utime utime,
                  Utime utime_published, bool track_drops = true);
  // A message that was received but not handled (undecodable, invalid, from the future).
  void onRejected(const std::string& channel);
  // A published message.
  void onPublished(const std::string& channel, Utime utime, Utime utime_published);
  void onPublishedAt(int slot, Utime utime, Utime utime_published);
  void onProcessing(double ms);
  void onError(const std::string& kind, const std::string& text, Utime when);
  void setMetric(const std::string& name, double value);
  // While set, the process reports STATE_ERROR: it cannot do its job (a device is missing).
  void setFault(bool fault) { fault_ = fault; }
  bool fault() const { return fault_; }
  // A process-specific condition named `key` (e.g. "vision"): while `reason` is non-empty the
  // state is at least STATE_WARN with the reason; an empty reason clears it.
  void setWarning(const std::string& key, const std::string& reason);

  // Fills a status message for the period ending at `now` and starts a new period.
  service_status_t takeStatus(Utime now);

  const ChannelStats* channel(const std::string& name, Direction d) const;
  std::int64_t errorCount(const std::string& kind) const;
  const std::string& lastError() const { return last_error_; }

 private:
  ChannelStats& stats(std::string_view name, Direction d) {
    return channels_[static_cast<std::size_t>(slot(name, d))];
  }

  std::string process_;
  int robot_id_;
  Utime start_;
  Utime period_start_;
  std::vector<ChannelStats> channels_;
  std::vector<float> processing_ms_;
  std::map<std::string, std::int64_t> errors_;
  std::string last_error_;
  Utime last_error_utime_ = 0;
  std::map<std::string, double> metrics_;
  std::int64_t errors_in_period_ = 0;
  bool fault_ = false;
  std::map<std::string, std::string> warnings_;
  Utime rate_grace_us_ = 2 * kMicrosPerSecond;
};

}  // namespace fieldline::bus
