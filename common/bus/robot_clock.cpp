#include "common/bus/robot_clock.hpp"

#include <stdexcept>

#include <spdlog/spdlog.h>

#include "common/config/config.hpp"

namespace fieldline::bus {

ClockError robotClockErrorFromEnvironment() {
  std::optional<ClockError> error;
  try {
    error = clockErrorFromEnvironment();
  } catch (const std::invalid_argument& e) {
    throw config::Error(std::string("robot clock: ") + e.what());
  }
  if (!error) return {};
  spdlog::info("robot clock: offset {:.3f} ms, drift {:.1f} ppm from {}",
               static_cast<double>(error->offset_us) * 1e-3, error->drift_ppm, error->reference_us);
  return *error;
}

}  // namespace fieldline::bus
