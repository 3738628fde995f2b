#include "common/bus/seq_tracker.hpp"

#include <algorithm>

namespace fieldline::bus {

double SeqTracker::plausibleGap(Utime from, Utime to) {
  // In long double: stamps are untrusted and their difference can overflow int64.
  const long double dt_s =
      std::max(0.0L, (static_cast<long double>(to) - static_cast<long double>(from)) * 1e-6L);
  return static_cast<double>(static_cast<long double>(kGapSlack) +
                             dt_s * static_cast<long double>(kMaxPublishRateHz));
}

SeqOutcome SeqTracker::onMessage(std::int64_t seq, Utime published) {
  using Kind = SeqOutcome::Kind;
  SeqOutcome out;
  out.previous = last_seq_;
  if (!started_) {
    started_ = true;
    last_seq_ = seq;
    last_published_ = published;
    return out;
  }
  auto adopt = [&](Kind kind, std::int64_t drops) {
    out.kind = kind;
    out.drops = drops;
    last_seq_ = seq;
    last_published_ = published;
    jump_seq_.reset();
    return out;
  };
  if (seq > last_seq_) {
    // Overflow-safe: both are >= 0.
    const std::int64_t missing = seq - last_seq_ - 1;
    if (missing == 0) return adopt(Kind::kInOrder, 0);
    if (static_cast<double>(missing) <= plausibleGap(last_published_, published)) {
      gap_low_ = last_seq_;
      gap_high_ = seq;
      return adopt(Kind::kGap, missing);
    }
    // Too far for the time that passed. If it continues a jump seen before, the publisher
    // really is there now.
    if (jump_seq_ && seq > *jump_seq_ &&
        static_cast<double>(seq - *jump_seq_ - 1) <= plausibleGap(jump_published_, published)) {
      gap_low_ = gap_high_ = -1;
      return adopt(Kind::kResync, 0);
    }
    jump_seq_ = seq;
    jump_published_ = published;
    out.kind = Kind::kSuspiciousJump;
    return out;
  }
  if (seq == last_seq_) {
    out.kind = Kind::kDuplicate;
    return out;
  }
  if (seq > gap_low_ && seq < gap_high_) {
    // A message we counted as lost arrived: the gap was a forged (or reordered) seq.
    const std::int64_t retracted = gap_high_ - gap_low_ - 1;
    gap_low_ = gap_high_ = -1;
    return adopt(Kind::kGapRetracted, -retracted);
  }
  gap_low_ = gap_high_ = -1;
  return adopt(Kind::kRestart, 0);
}

}  // namespace fieldline::bus
