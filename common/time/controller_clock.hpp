// Maps a device's own clock (a motor controller's µs since it started) onto the host's clock, so
// that a sample is stamped with the physical time it was taken rather than the time the serial
// link happened to deliver it. The offset host - device of each sample is its receive time minus
// its device time: the true clock offset plus the transport delay, which jitters upwards only
// (queueing, a busy reader). The low envelope of the offsets over a sliding window of device time
// is the offset with the least delay; a sample is stamped
//   device time + low envelope - latency,
// latency being the configured delay of that least-delayed path (sampling to receipt). The
// window follows a slow drift of either clock.
//
// Robust to:
//   - a device restart: its clock runs backwards, or forward by far more than the host's: the
//     window starts over (counted in restarts());
//   - a step of the host clock: backwards, the envelope follows at once (a smaller offset);
//     forwards, every offset stays above the envelope by at least `step_us` for `confirm_us` of
//     host time: the window starts over from them;
//   - a starved reader: samples read together after a stall carry large offsets, but the newest
//     of them has the ordinary one, and the envelope never rises from them. Feed all samples of
//     one read to observe() before stamping any. Samples of one read (the same receive time)
//     never age the entries before them out of the window: a backlog longer than the window,
//     read in several chunks, keeps the least-delayed entry from before the stall until a later
//     read brings an ordinary one.
// Plain logic on times the caller passes in (no clock, no LCM).
#pragma once

#include <cstdint>
#include <deque>
#include <optional>

#include "common/time/clock.hpp"

namespace fieldline {

class ControllerClockMap {
 public:
  struct Params {
    // Sliding window of device time over which the envelope is the minimum offset, µs.
    Utime window_us = 2'000'000;
    // Delay from sampling to receipt on the least-delayed path, µs.
    Utime latency_us = 0;
    // A forward host step: offsets this far above the envelope ...
    Utime step_us = 200'000;
    // ... over this long of host time (so one late read after a stall is not a step), µs.
    Utime confirm_us = 500'000;
    // The device clock ran ahead of the host's by more than this between two samples: it
    // restarted, µs.
    Utime max_device_jump_us = 1'000'000;
  };

  ControllerClockMap() : ControllerClockMap(Params{}) {}
  explicit ControllerClockMap(Params params) : params_(params) {}

  // One sample: its device time and the host time it was received at.
  void observe(std::int64_t device_us, Utime receive_us);
  // The physical host time of a sample taken at `device_us`: device time + envelope - latency.
  // Empty before the first observe().
  std::optional<Utime> stamp(std::int64_t device_us) const;
  // Offset host - device of the least-delayed recent sample, µs (empty before any).
  std::optional<std::int64_t> envelope() const;

  // Times the window started over (device restart, host clock step), after the first sample.
  std::uint64_t restarts() const { return restarts_; }
  void reset();

 private:
  struct Entry {
    std::int64_t device_us;
    std::int64_t offset;
    Utime receive_us;
  };
  void restart(std::int64_t device_us, std::int64_t offset, Utime receive_us);

  Params params_;
  // Monotone queue: offsets strictly increasing from front to back; the front is the minimum.
  std::deque<Entry> window_;
  std::optional<std::int64_t> last_device_;
  Utime last_receive_ = 0;
  // The current run of samples above the envelope by step_us: since when (host time), and its
  // smallest offset.
  std::optional<Utime> high_since_;
  std::int64_t high_min_ = 0;
  std::uint64_t restarts_ = 0;
};

}  // namespace fieldline
