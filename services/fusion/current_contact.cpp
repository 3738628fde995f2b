#include "services/fusion/current_contact.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace fieldline::fusion {

CurrentContactDetector::CurrentContactDetector(const robot::RobotParams& robot,
                                               CurrentContactParams params)
    : params_(params) {
  if (!(params_.force_threshold_n >= 0.0) || params_.samples < 1 ||
      !(params_.max_current_a > 0.0) || !(params_.max_interval_s > 0.0)) {
    throw std::invalid_argument(
        "current contact: threshold >= 0, samples >= 1, max current and interval > 0");
  }
  const double ticks = robot.ticksPerWheelRevolution();
  share_kg_ = robot.mass / robot.wheelCount();
  for (const robot::WheelGeometry& wheel : robot.wheels) {
    metres_per_tick_.push_back(2.0 * std::numbers::pi * wheel.radius / ticks);
    // Motor torque k_t * I, through the gear to the wheel, at the wheel's radius.
    newtons_per_amp_.push_back(robot.motor.torque_constant * robot.gear_ratio / wheel.radius);
  }
}

namespace {

// The reason to refuse a sample's currents (or ticks) for a robot of `wheels` wheels, empty when
// they are sound.
std::string currentRejection(const OdometrySample& sample, std::size_t wheels,
                             double max_current_a) {
  if (sample.wheel_current.size() != wheels || sample.ticks.size() != wheels) {
    // Currents or ticks for another number of wheels: nothing to compare them with.
    return "current_wheel_count";
  }
  std::string rejection;
  for (const double c : sample.wheel_current) {
    if (!std::isfinite(c)) {
      rejection = "current_not_finite";
    } else if (std::abs(c) > max_current_a && rejection.empty()) {
      rejection = "current_absurd";
    }
  }
  return rejection;
}

// False when the sample cannot follow the history's last entry: time backwards or a gap, the
// controller restarted or its clock comes and goes.
template <typename Entry>
bool follows(const OdometrySample& sample, const Entry& last, double max_interval_s) {
  if (sample.utime <= last.utime ||
      static_cast<double>(sample.utime - last.utime) * 1e-6 > max_interval_s) {
    return false;
  }
  return (sample.controller_utime == 0) == (last.controller_utime == 0) &&
         (sample.controller_utime == 0 || sample.controller_utime > last.controller_utime);
}

}  // namespace

CurrentContactDetector::Result CurrentContactDetector::add(const OdometrySample& sample) {
  Result result;
  if (!enabled()) return result;
  auto restart = [&] {
    history_.clear();
    beyond_ = 0;
  };
  if (!sample.has_currents || sample.resync) {
    restart();
    return result;
  }
  result.rejection = currentRejection(sample, metres_per_tick_.size(), params_.max_current_a);
  if (!result.rejection.empty()) {
    restart();
    return result;
  }
  if (!history_.empty() && !follows(sample, history_.back(), params_.max_interval_s)) restart();
  history_.push_back({sample.utime, sample.controller_utime, sample.ticks, sample.wheel_current});
  if (history_.size() > 4) history_.pop_front();
  if (history_.size() < 4) return result;

  // Periods: p1 = (h0, h1], p2 = (h1, h2] (judged: its currents are h2's), p3 = (h2, h3].
  const Entry& h0 = history_[0];
  const Entry& h1 = history_[1];
  const Entry& h2 = history_[2];
  const Entry& h3 = history_[3];
  const bool controller_clock = h0.controller_utime != 0;
  auto seconds = [&](const Entry& a, const Entry& b) {
    return static_cast<double>(controller_clock ? b.controller_utime - a.controller_utime
                                                : b.utime - a.utime) *
           1e-6;
  };
  const double t1 = seconds(h0, h1);
  const double t2 = seconds(h1, h2);
  const double t3 = seconds(h2, h3);
  for (const double t : {t1, t2, t3}) {
    if (!(t > 0.0 && t <= params_.max_interval_s)) {
      restart();
      return result;
    }
  }
  double largest = 0.0;
  for (std::size_t i = 0; i < metres_per_tick_.size(); ++i) {
    // Mean speeds of the three periods (tick differences wrap like the counters).
    auto speed = [&](const Entry& a, const Entry& b, double dt) {
      const auto d = static_cast<std::int32_t>(static_cast<std::uint32_t>(b.ticks[i]) -
                                               static_cast<std::uint32_t>(a.ticks[i]));
      return d * metres_per_tick_[i] / dt;
    };
    const double v1 = speed(h0, h1, t1);
    const double v2 = speed(h1, h2, t2);
    const double v3 = speed(h2, h3, t3);
    // The mean acceleration over p2: the mean of the accelerations at its two ends, each the
    // slope between the neighbouring periods' mean speeds (centred there).
    const double a_start = (v2 - v1) / (0.5 * (t1 + t2));
    const double a_end = (v3 - v2) / (0.5 * (t2 + t3));
    const double acceleration = 0.5 * (a_start + a_end);
    const double residual = h2.current[i] * newtons_per_amp_[i] - share_kg_ * acceleration;
    largest = std::max(largest, std::abs(residual));
  }
  last_residual_n_ = largest;
  beyond_ = largest > params_.force_threshold_n ? beyond_ + 1 : 0;
  if (beyond_ >= params_.samples) result.contact = h1.utime;
  return result;
}

}  // namespace fieldline::fusion
