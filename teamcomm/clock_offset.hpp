// A teammate's clock offset and drift from the round trips carried in the team packets
// (NTP-style, B-Human's BNTP): we sent at t1 (our clock), the teammate received at t2 and sent
// its next packet at t3 (its clock), we received that at t4 (our clock). Then
//   offset (theirs - ours) = ((t2 - t1) + (t3 - t4)) / 2,  round trip = (t4 - t1) - (t3 - t2),
// and the offset's error is at most half the round trip. Over a sliding window the smallest delays
// win: the lower envelope of t2 - t1 (offset plus the delay there) and the upper envelope of
// t3 - t4 (offset minus the delay back), each a line fitted to the convex hull of its points
// (so drift is a line fit too), taken separately for each direction so the best packet each way
// need not fall in the same round trip. Their mean is the offset line, exact when the smallest
// delays are equal both ways.
//
// A clock can step (NTP, a reboot, a restarted robot whose clock differs): a round trip whose
// offset interval [t3 - t4, t2 - t1] misses the fitted line by more than the fit's own error
// contradicts it. One such round trip is held aside (a bad stamp must not bend the fit); three in
// a row that agree with each other are a step: the window restarts from them, the step is
// counted and its size kept, and the estimate says it is converging until its round trips span
// `min_fit_span_us` again.
// Plain library: no clock, no I/O.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include "common/time/clock.hpp"

namespace fieldline::teamcomm {

struct RoundTrip {
  Utime t1_our_send = 0;
  Utime t2_their_receive = 0;
  Utime t3_their_send = 0;
  Utime t4_our_receive = 0;
};

struct OffsetOptions {
  // Samples older than this (our clock) are forgotten.
  Utime window_us = 20'000'000;
  // Round trips above this are not clock information but queueing (or bogus).
  Utime max_round_trip_us = 500'000;
  // Stamping noise, µs: round trips this far below zero are still plausible.
  double min_sigma_us = 250.0;
  // Drift is fitted only over at least this much time; shorter histories assume none.
  Utime min_fit_span_us = 3'000'000;
  // Drifts beyond this are implausible for a quartz clock and are clamped, ppm.
  double max_drift_ppm = 500.0;
  // Round trips in a row that contradict the fit (and agree with each other) to call it a step.
  int step_confirmations = 3;
  // A round trip contradicts the fit when its interval misses the line by more than the fit's
  // error bound (half the smallest round trip) plus this, µs.
  double step_slack_us = 1000.0;
};

// What became of a round trip given to the estimator.
enum class RoundTripUse : std::uint8_t {
  // Part of the fit now.
  kAdded = 0,
  // Impossible (negative beyond the stamping noise, a negative hold time) or too long.
  kRefused,
  // It contradicts the fit: held aside as evidence of a clock step.
  kHeld,
  // It confirmed a step: the fit restarted from the held round trips and this one.
  kStep,
};
const char* toString(RoundTripUse u);

struct ClockStep {
  // When it was confirmed (t4 of the confirming round trip, our clock).
  Utime confirmed_utime = 0;
  // New offset minus the old fit's, at that time, µs.
  double size_us = 0.0;
};

struct OffsetEstimate {
  // Their clock minus ours at the time asked for, µs.
  double offset_us = 0.0;
  // d(offset)/d(our time), parts per million.
  double drift_ppm = 0.0;
  // Smallest round trip in the window, µs.
  Utime min_round_trip_us = 0;
  // Bound on the offset's error: half the smallest round trip, µs.
  double uncertainty_us = 0.0;
};

class ClockOffsetEstimator {
 public:
  explicit ClockOffsetEstimator(OffsetOptions options = {});

  // Adds a round trip (or holds it aside, or confirms a step with it, see RoundTripUse).
  RoundTripUse add(const RoundTrip& rt);
  // The estimate at `now_ours`, or nothing before the first usable round trip.
  std::optional<OffsetEstimate> estimate(Utime now_ours) const;
  // A teammate's time converted to ours (and back), using the estimate at that time.
  std::optional<Utime> toOurs(Utime their_utime) const;
  std::optional<Utime> toTheirs(Utime our_utime) const;
  std::size_t samples() const { return samples_.size(); }
  // Whether the round trip would be used (kAdded, kHeld or kStep) without adding it.
  bool plausible(const RoundTrip& rt) const;
  // Steps confirmed so far, and the last one.
  std::uint64_t steps() const { return steps_; }
  std::optional<ClockStep> lastStep() const { return last_step_; }
  // Round trips held aside now (contradicting the fit, not yet a step).
  std::size_t held() const { return held_.size(); }
  // After a step: the fit's round trips do not yet span min_fit_span_us (no drift yet, few
  // samples). False before any step and once they do.
  bool converging() const;
  // Forgets everything but the step count (e.g. the teammate's packets were refused as stale
  // for too long and no round trip came to say why).
  void reset();

 private:
  struct Sample {
    Utime when = 0;            // t4, our clock
    Utime sent = 0;            // t1, our clock
    double forward_us = 0.0;   // t2 - t1: offset plus the delay to them
    double backward_us = 0.0;  // t3 - t4: offset minus the delay back
    Utime round_trip_us = 0;
  };
  // One direction's points (t our clock, y the delay-carrying difference) in (t, y) order, and
  // their lower convex hull (Andrew's monotone chain), kept as round trips come and go: a round
  // trip added last extends the hull, the oldest leaving rebuilds only its first edge's span, so
  // a refit costs a pass over the window, not a sort and a hull per round trip (issue 32). The
  // hull's decisions use differences of times only, so they are those the whole chain over the
  // same points makes (clock_offset_test compares with it, round trip by round trip).
  struct Point {
    Utime t = 0;
    double y = 0.0;
    bool operator<(const Point& o) const { return t < o.t || (t == o.t && y < o.y); }
    bool operator==(const Point& o) const { return t == o.t && y == o.y; }
  };
  struct Envelope {
    std::deque<Point> points;
    std::vector<Point> hull;
    std::vector<Point> scratch;
    // The sum of the points' t - base, exact, for their mean time (base: the first point's t).
    Utime base = 0;
    std::int64_t sum_t = 0;
    // The mean of the points' t - reference, as summing them in double gives it whenever that
    // sum is exact (|sum| < 2^53 µs: every window this side of centuries).
    double meanTime(Utime reference) const;
    void insert(Point p);
    void erase(Point p);
    void rebuild();
    void clear();
  };
  void refit();
  // Both envelopes from samples_ (after the window restarted from held round trips).
  void rebuildEnvelopes();
  // Whether `s`'s offset interval contains the fitted line within its error and the slack.
  bool agreesWithFit(const Sample& s) const;

  OffsetOptions options_;
  std::deque<Sample> samples_;
  // (t1, t2 - t1) and (t4, t4 - t3) of samples_: the envelopes' points.
  Envelope forward_;
  Envelope backward_;
  // Contradicting round trips in a row, oldest first.
  std::deque<Sample> held_;
  std::uint64_t steps_ = 0;
  std::optional<ClockStep> last_step_;
  bool after_step_ = false;
  // Line offset(t) = intercept + slope * (t - reference), refitted on every add.
  bool fitted_ = false;
  Utime reference_ = 0;
  double intercept_us_ = 0.0;
  double slope_ = 0.0;
  Utime min_round_trip_us_ = 0;
  // The smallest round trip of samples_ is known (else it is found again at the next refit).
  bool min_round_trip_known_ = false;
};

}  // namespace fieldline::teamcomm
