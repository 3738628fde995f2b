// A clock that runs off another by an offset and a rate error, as a robot's own computer clock
// runs off true time: now = base + offset + drift * (base - reference). The simulated team gives
// every process of robot N the same offset, drift and reference, so they agree with each other
// and disagree with the other robots as six machines would.
#pragma once

#include <cmath>
#include <cstdlib>
#include <optional>
#include <stdexcept>
#include <string>

#include "common/time/clock.hpp"

namespace fieldline {

class OffsetClock final : public Clock {
 public:
  OffsetClock(const Clock& base, Utime offset_us, double drift_ppm, Utime reference_us)
      : base_(base), offset_us_(offset_us), drift_(drift_ppm * 1e-6), reference_us_(reference_us) {}
  Utime now() const override {
    const Utime t = base_.now();
    return t + offset_us_ +
           static_cast<Utime>(std::llround(drift_ * static_cast<double>(t - reference_us_)));
  }
  // Elapsed time is the base's: a robot's clock error changes stamps, not how time passes here.
  Utime monotonicNow() const override { return base_.monotonicNow(); }
  Utime offset_us() const { return offset_us_; }
  double drift_ppm() const { return drift_ * 1e6; }

 private:
  const Clock& base_;
  Utime offset_us_;
  double drift_;
  Utime reference_us_;
};

struct ClockError {
  Utime offset_us = 0;
  double drift_ppm = 0.0;
  // Base time at which the offset is exactly offset_us, µs since the epoch.
  Utime reference_us = 0;
};

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
  const auto offset = read("FIELDLINE_CLOCK_OFFSET_US");
  const auto drift = read("FIELDLINE_CLOCK_DRIFT_PPM");
  const auto reference = read("FIELDLINE_CLOCK_REFERENCE_US");
  if (!offset && !drift) return std::nullopt;
  if (drift && std::fabs(*drift) > 1000.0) {
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
