// Sequence accounting for one publisher of one channel: which seq gaps are messages lost on the
// way (DROPS) and which are not. Shared by every receiver's SERVICE_STATUS (status.hpp) and by
// fieldline-bus-stats, so both count the same way. Plain C++, no bus.
//
// A gap counts as drops only when a real publisher could have made it:
// - no publisher sends faster than kMaxPublishRateHz, so between two of its messages whose
//   utime_published are dt apart at most kGapSlack + dt * kMaxPublishRateHz messages can be
//   missing. A larger jump is *suspicious* (a forged or corrupted seq): counted, not adopted, and
//   no drops; if the next message continues the jumped sequence, the publisher really went on
//   there and it is a resync (counted once, no drops).
// - a message that arrives inside the last counted gap proves the gap was no loss (the red team
//   sent copies of the real publisher's id with seq + 1000, each followed by the real next seq):
//   the gap's drops are taken back and the message counts as suspicious.
// - any other step back is a restart (a sender without publisher id) and restarts the tracking.
#pragma once

#include <cstdint>
#include <optional>

#include "common/time/clock.hpp"

namespace fieldline::bus {

struct SeqOutcome {
  enum class Kind : std::int8_t {
    // The first message of this publisher, or the next seq.
    kInOrder,
    // A plausible gap: `drops` messages lost.
    kGap,
    // A jump no publisher could make in the time between the two messages: not adopted.
    kSuspiciousJump,
    // The same seq again.
    kDuplicate,
    // A message inside the last gap: `drops` is negative, the gap's count taken back.
    kGapRetracted,
    // The sequence really moved on after a suspicious jump: adopted, no drops.
    kResync,
    // A step back outside the last gap: the publisher restarted its count.
    kRestart,
  };
  Kind kind = Kind::kInOrder;
  // Change of the drop count (negative for kGapRetracted).
  std::int64_t drops = 0;
  // The seq before this message (the tracker's last), for messages about it.
  std::int64_t previous = 0;

  bool suspicious() const {
    return kind == Kind::kSuspiciousJump || kind == Kind::kDuplicate || kind == Kind::kGapRetracted;
  }
};

class SeqTracker {
 public:
  // Faster than any fieldline channel is published (the simulator's 100 Hz world is the fastest
  // by default; its limit is 1 kHz).
  static constexpr double kMaxPublishRateHz = 1000.0;
  // Jitter allowance: this many missing messages are plausible whatever the stamps say.
  static constexpr std::int64_t kGapSlack = 5;

  // A message with `seq` (>= 0) published at `published` (the publisher's clock).
  SeqOutcome onMessage(std::int64_t seq, Utime published);
  // The seq of the last message adopted.
  std::int64_t lastSeq() const { return last_seq_; }

 private:
  // How many missing messages a publisher could have produced between stamps `from` and `to`.
  static double plausibleGap(Utime from, Utime to);

  bool started_ = false;
  std::int64_t last_seq_ = 0;
  Utime last_published_ = 0;
  // The last gap counted as drops: the seqs strictly between gap_low_ and gap_high_.
  std::int64_t gap_low_ = -1;
  std::int64_t gap_high_ = -1;
  // A suspicious jump not adopted, kept to see whether the sequence goes on from it.
  std::optional<std::int64_t> jump_seq_;
  Utime jump_published_ = 0;
};

}  // namespace fieldline::bus
