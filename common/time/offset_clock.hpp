// A clock that runs off another by an offset and a rate error, as a robot's own computer clock
// runs off true time: now = base + offset + drift * (base - reference). The simulated team gives
// every process of robot N the same offset, drift and reference, so they agree with each other
// and disagree with the other robots as six machines would.
//
//   RobotClock clock(ClockError{...});     // owns the system clock it runs off
//   clock.toTruth(clock.now())             // == the system (true) time, to rounding
#pragma once

#include <cmath>
#include <cstdlib>
#include <optional>
#include <stdexcept>
#include <string>

#include "common/time/clock.hpp"

namespace fieldline {

struct ClockError {
  Utime offset_us = 0;
  double drift_ppm = 0.0;
  // Base time at which the offset is exactly offset_us, µs since the epoch.
  Utime reference_us = 0;
};

// own = truth + offset + drift * (truth - reference), rounded to the µs; and its inverse.
inline Utime truthToOwn(const ClockError& e, Utime truth) {
  const double d = e.drift_ppm * 1e-6;
  return truth + e.offset_us +
         static_cast<Utime>(std::llround(d * static_cast<double>(truth - e.reference_us)));
}
inline Utime ownToTruth(const ClockError& e, Utime own) {
  const double d = e.drift_ppm * 1e-6;
  // own - offset - reference = (truth - reference) * (1 + d)
  const double since = static_cast<double>(own - e.offset_us - e.reference_us) / (1.0 + d);
  return e.reference_us + static_cast<Utime>(std::llround(since));
}

class OffsetClock final : public Clock {
 public:
  OffsetClock(const Clock& base, Utime offset_us, double drift_ppm, Utime reference_us)
      : base_(base), error_{offset_us, drift_ppm, reference_us} {}
  OffsetClock(const Clock& base, const ClockError& error) : base_(base), error_(error) {}
  Utime now() const override { return truthToOwn(error_, base_.now()); }
  // Elapsed time is the base's: a robot's clock error changes stamps, not how time passes here.
  Utime monotonicNow() const override { return base_.monotonicNow(); }
  // The true time of a reading of this clock, and back (the base's own conversions compose).
  Utime toTruth(Utime own) const;
  Utime fromTruth(Utime truth) const;
  Utime offset_us() const { return error_.offset_us; }
  double drift_ppm() const { return error_.drift_ppm; }
  const ClockError& error() const { return error_; }

 private:
  const Clock& base_;
  ClockError error_;
};

// The clock of one robot of the simulated team: the system clock with that robot's error (none:
// the system clock itself). Every process of the robot builds one from the same error, e.g. with
// bus::robotClockFromEnvironment(). Not copyable: nodes keep a reference to it.
class RobotClock final : public Clock {
 public:
  explicit RobotClock(const ClockError& error = {}) : offset_(system_, error) {}
  RobotClock(const RobotClock&) = delete;
  RobotClock& operator=(const RobotClock&) = delete;
  Utime now() const override { return offset_.now(); }
  Utime monotonicNow() const override { return system_.monotonicNow(); }
  Utime toTruth(Utime own) const { return offset_.toTruth(own); }
  Utime fromTruth(Utime truth) const { return offset_.fromTruth(truth); }
  const ClockError& error() const { return offset_.error(); }

 private:
  SystemClock system_;
  OffsetClock offset_;
};

// The simulator's true time of a reading `own` of `clock`, and back: robot clocks (OffsetClock,
// RobotClock) convert, every other clock (system, simulated) is the truth. The processes that meet
// the simulator's truth (the simulated camera, a cheating pilot, the bus's stamp checks of
// simulator messages) convert with these.
inline Utime toTruth(const Clock& clock, Utime own) {
  if (const auto* r = dynamic_cast<const RobotClock*>(&clock)) return r->toTruth(own);
  if (const auto* o = dynamic_cast<const OffsetClock*>(&clock)) return o->toTruth(own);
  return own;
}
inline Utime fromTruth(const Clock& clock, Utime truth) {
  if (const auto* r = dynamic_cast<const RobotClock*>(&clock)) return r->fromTruth(truth);
  if (const auto* o = dynamic_cast<const OffsetClock*>(&clock)) return o->fromTruth(truth);
  return truth;
}
inline Utime OffsetClock::toTruth(Utime own) const {
  return fieldline::toTruth(base_, ownToTruth(error_, own));
}
inline Utime OffsetClock::fromTruth(Utime truth) const {
  return truthToOwn(error_, fieldline::fromTruth(base_, truth));
}

// The environment variables that carry a simulated robot's clock error to its processes.
inline constexpr const char* kClockOffsetVariable = "FIELDLINE_CLOCK_OFFSET_US";
inline constexpr const char* kClockDriftVariable = "FIELDLINE_CLOCK_DRIFT_PPM";
inline constexpr const char* kClockReferenceVariable = "FIELDLINE_CLOCK_REFERENCE_US";
// Largest drift a robot's clock may have, ppm (a crystal is good to 20-100).
inline constexpr double kMaxClockDriftPpm = 1000.0;

// Reads FIELDLINE_CLOCK_OFFSET_US, FIELDLINE_CLOCK_DRIFT_PPM and FIELDLINE_CLOCK_REFERENCE_US
// (all optional; absent means a true clock). Throws std::invalid_argument for a malformed value,
// a drift beyond +-1000 ppm, or a drift without a reference (the robot's processes would
// disagree).
inline std::optional<ClockError> clockErrorFromEnvironment() {
  auto read = [](const char* name) -> std::optional<double> {
    const char* text = std::getenv(name);
    if (!text || !*text) return std::nullopt;
    char* end = nullptr;
    const double v = std::strtod(text, &end);
    if (end == text || *end != '\0' || !std::isfinite(v)) {
      throw std::invalid_argument(std::string(name) + "=" + text + " is not a number");
    }
    return v;
  };
  const auto offset = read(kClockOffsetVariable);
  const auto drift = read(kClockDriftVariable);
  const auto reference = read(kClockReferenceVariable);
  if (!offset && !drift) return std::nullopt;
  if (offset && std::fabs(*offset) > 3600.0 * 1e6) {
    throw std::invalid_argument("FIELDLINE_CLOCK_OFFSET_US beyond +-1 h");
  }
  if (drift && std::fabs(*drift) > kMaxClockDriftPpm) {
    throw std::invalid_argument("FIELDLINE_CLOCK_DRIFT_PPM beyond +-1000 ppm");
  }
  if (drift && *drift != 0.0 && !reference) {
    throw std::invalid_argument(
        "FIELDLINE_CLOCK_DRIFT_PPM needs FIELDLINE_CLOCK_REFERENCE_US (the time the drift counts "
        "from, the same for every process of the robot)");
  }
  return ClockError{static_cast<Utime>(offset.value_or(0.0)), drift.value_or(0.0),
                    static_cast<Utime>(reference.value_or(0.0))};
}

}  // namespace fieldline
