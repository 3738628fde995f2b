// A robot's clock against a recording's time. A log's events carry the time the recording
// machine received them (its own clock); the messages inside carry the publishing robot's clock,
// which in the simulated team runs off by an offset and a drift (config/launch/sim_team.yaml) and
// on a real team is whatever the robot's computer says. Replay, evaluation and the viewer put the
// two on one time line with this model:
//
//   own = log + offset + drift * (log - reference)      (ClockError, common/time/offset_clock.hpp)
//
// It comes from the recording itself (RECORDING_INFO, written by fieldline-record), from the
// user (fieldline-replay --clock-offset), or, for recordings that do not carry it (lcm-logger's,
// scripts/demo --record before recordings described themselves), from the traffic: a message is
// received after it was published, so utime_published - log time is the robot's offset minus a
// small, positive delivery delay; its upper envelope over time is the clock.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <fieldline/header_t.hpp>

#include "common/time/offset_clock.hpp"

namespace fieldline::recording {

enum class ClockSource {
  // Nothing known: the robot's stamps are taken as the log's clock.
  kNone,
  // Written into the recording by the recorder (the launch file's clock, or none on a real robot).
  kRecorded,
  // Fitted to the traffic of the log.
  kEstimated,
  // Given on the command line.
  kGiven,
};

const char* toString(ClockSource source);

struct RobotClockModel {
  int robot_id = 0;
  ClockError error;
  ClockSource source = ClockSource::kNone;
  // kEstimated: the messages the fit rests on, and how far below the fitted clock their
  // utime_published lay (the delivery delay): median and 99th percentile, ms.
  std::int64_t samples = 0;
  double delay_p50_ms = 0.0;
  double delay_p99_ms = 0.0;

  // The robot's clock reading at log time `log`, and back.
  Utime ownAt(Utime log) const { return truthToOwn(error, log); }
  Utime logAt(Utime own) const { return ownToTruth(error, own); }
  // "offset +312.0 ms, drift +38.0 ppm (estimated from 1501 messages, delay p50 0.2 ms)".
  std::string describe() const;
};

// One received message: the log's time of it and its header.utime_published.
struct StampSample {
  Utime log_time = 0;
  Utime published = 0;
};

struct ClockFitOptions {
  // Samples are taken in windows of this length; each window's upper envelope is a high quantile
  // of utime_published - log time (the quickest deliveries).
  double window_s = 2.0;
  double envelope_quantile = 0.95;
  // A window needs this many samples to count.
  int min_window_samples = 5;
  // The drift is fitted only over a log at least this long (a shorter one gives it no leverage:
  // 50 ppm over 30 s is 1.5 ms); below it the drift is 0.
  double min_drift_span_s = 60.0;
};

// The clock that fits `samples` (any order), or nothing when there are too few (no window with
// min_window_samples). The reference time is the first sample's log time.
std::optional<RobotClockModel> fitClock(std::vector<StampSample> samples,
                                        const ClockFitOptions& options = {});

// The header every fieldline message starts with, read from encoded bytes without decoding the
// rest (an image's pixels); nothing when the bytes are too short.
std::optional<header_t> peekHeader(const void* data, int size);

// Reads the log once and fits a clock per robot_id found in the headers of fieldline channels
// (channels.hpp; 0 is the simulator). Throws bus::LogError when the log cannot be read.
std::map<int, RobotClockModel> estimateClocks(const std::string& path,
                                              const ClockFitOptions& options = {});

}  // namespace fieldline::recording
