#include "services/world_sim/firmware.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace fieldline::world_sim {

namespace proto = serial;

GyroModel::GyroModel(const robot::GyroParams& params, std::uint64_t seed)
    : params_(params), rng_(seed) {
  bias_ = params_.bias_sigma * normal_(rng_);
  scale_error_ = params_.scale_sigma * normal_(rng_);
}

void GyroModel::step(double true_rate, double dt) {
  if (!(dt > 0.0)) return;
  bias_ += params_.bias_walk * std::sqrt(dt) * normal_(rng_);
  // One rate sample: its white noise is the density over the sensor's bandwidth, which cannot
  // exceed half the rate the samples come at.
  const double bandwidth = std::min(params_.bandwidth, 0.5 / dt);
  double rate = (1.0 + scale_error_) * true_rate + bias_ +
                params_.noise_density * std::sqrt(bandwidth) * normal_(rng_);
  if (std::abs(rate) >= params_.range) {
    rate = std::copysign(params_.range, rate);
    ++saturated_;
  }
  if (params_.lsb > 0.0) rate = std::round(rate / params_.lsb) * params_.lsb;
  angle_ += rate * dt;
  ++samples_;
}

FirmwareEmulator::FirmwareEmulator(const robot::RobotParams& params, std::uint64_t clock_offset_us,
                                   CurrentModel currents)
    : params_(params),
      clock_offset_us_(clock_offset_us),
      currents_(currents),
      noise_rng_(clock_offset_us ^ 0x5eed'c0ffeeULL) {
  messages_.reserve(16);
  // Its own random stream: the currents' noise stays what it was without a gyro.
  if (params.gyro.present) gyro_.emplace(params.gyro, clock_offset_us ^ 0x6e70'0bad'cafeULL);
}

void FirmwareEmulator::gyroStep(double true_rate, double dt) {
  if (gyro_) gyro_->step(true_rate, dt);
}

robot::WheelVector FirmwareEmulator::wheelCurrents(const robot::RobotParams& params,
                                                   const CurrentModel& model,
                                                   const WheelState& previous,
                                                   const WheelState& now, double dt,
                                                   const robot::WheelVector& unit_noise) {
  constexpr double kGravity = 9.81;
  const int wheels = params.wheelCount();
  for (const robot::WheelVector* v :
       {&previous.speeds, &previous.slip, &now.speeds, &now.slip, &unit_noise}) {
    if (v->size() != wheels) {
      throw std::invalid_argument("wheel currents: " + std::to_string(v->size()) + " values for " +
                                  std::to_string(wheels) + " wheels");
    }
  }
  const double share = params.mass / wheels;
  const double friction_limit = model.friction_coefficient * share * kGravity;
  const double saturation = std::max(model.saturation_slip_speed, 1e-6);
  robot::WheelVector current(wheels);
  for (int i = 0; i < wheels; ++i) {
    const double acceleration = (now.speeds[i] - previous.speeds[i]) / dt;
    const double slip_speed = (now.slip[i] - previous.slip[i]) / dt;
    const double force =
        share * acceleration + friction_limit * std::clamp(slip_speed / saturation, -1.0, 1.0);
    const double torque = force * params.wheels[static_cast<std::size_t>(i)].radius /
                          static_cast<double>(params.gear_ratio);
    current[i] = torque / params.motor.torque_constant + model.noise_a * unit_noise[i];
  }
  return current;
}

std::uint64_t FirmwareEmulator::controllerTimeUs(double t) const {
  return clock_offset_us_ + static_cast<std::uint64_t>(std::llround(std::max(t, 0.0) * 1e6));
}

void FirmwareEmulator::receive(std::span<const std::uint8_t> bytes, double t,
                               std::vector<std::uint8_t>& reply) {
  messages_.clear();
  const std::uint64_t bad_before = decoder_.stats().badFrames();
  decoder_.feed(bytes, messages_);
  for (const auto& m : messages_) {
    if (const auto* cmd = std::get_if<proto::VelocityCommand>(&m)) {
      pending_.push_back({t + params_.controller_latency,
                          {proto::fromQ15(cmd->vx_q15), proto::fromQ15(cmd->vy_q15),
                           proto::fromQ15(cmd->omega_q15)}});
      last_command_time_ = t;
      last_command_seq_ = cmd->seq;
      ++stats_.commands_accepted;
    } else if (const auto* hello = std::get_if<proto::Hello>(&m)) {
      if (hello->role == proto::Role::kHost) {
        proto::Hello answer;
        answer.role = proto::Role::kController;
        answer.firmware_version = kEmulatorFirmwareVersion;
        answer.ticks_per_revolution = static_cast<std::uint16_t>(params_.ticksPerWheelRevolution());
        answer.odometry_period_us =
            static_cast<std::uint32_t>(std::lround(1e6 / params_.odometry_rate));
        proto::encode(answer, reply);
        ++stats_.hellos_answered;
      }
    }
    // Odometry and error reports are controller-to-host only; a controller ignores them.
  }
  const std::uint64_t bad_now = decoder_.stats().badFrames();
  if (bad_now > bad_before) {
    proto::encode(
        proto::ErrorReport{proto::ErrorCode::kBadFrame, static_cast<std::uint32_t>(bad_now)},
        reply);
  }
}

bool FirmwareEmulator::watchdogStopped(double t) const {
  return last_command_time_ < 0.0 || t - last_command_time_ > params_.watchdog_timeout;
}

robot::NormalizedCommand FirmwareEmulator::motorCommand(double t) {
  while (!pending_.empty() && pending_.front().apply_at <= t) {
    active_ = pending_.front().command;
    pending_.pop_front();
  }
  const bool stopped = watchdogStopped(t);
  if (stopped && !was_stopped_) ++stats_.watchdog_stops;
  was_stopped_ = stopped;
  if (stopped) {
    active_ = {};
    pending_.clear();
  }
  return active_;
}

void FirmwareEmulator::sample(double t, const robot::TickCounts& ticks,
                              std::vector<std::uint8_t>& out, const WheelState* wheels) {
  proto::OdometrySample s;
  s.seq = sample_seq_;
  s.controller_time_us = controllerTimeUs(t);
  s.ticks.assign(ticks.begin(), ticks.end());
  if (watchdogStopped(t)) s.status |= proto::kStatusWatchdog;
  if (sample_seq_ == 0) s.status |= proto::kStatusReset;
  const std::uint64_t bad = decoder_.stats().badFrames();
  if (bad > bad_frames_reported_) s.status |= proto::kStatusRxErrors;
  bad_frames_reported_ = bad;
  s.last_command_seq = last_command_seq_;
  if (currents_.enabled && wheels) {
    // The first sample has no period to average over: no current yet.
    if (last_wheels_ && t > last_wheels_t_) {
      const int n = params_.wheelCount();
      robot::WheelVector noise(n);
      for (int i = 0; i < n; ++i)
        noise[i] = normal_(noise_rng_);
      const robot::WheelVector amps =
          wheelCurrents(params_, currents_, *last_wheels_, *wheels, t - last_wheels_t_, noise);
      auto& ma = s.current_ma.emplace();
      for (int i = 0; i < n; ++i)
        ma.push_back(
            static_cast<std::int16_t>(std::lround(std::clamp(amps[i] * 1e3, -32767.0, 32767.0))));
    }
    last_wheels_ = *wheels;
    last_wheels_t_ = t;
  }
  if (gyro_) {
    // Microradians since the start, wrapping as int32 (the host takes differences).
    const auto urad = static_cast<std::int64_t>(std::llround(gyro_->angle() * 1e6));
    s.gyro_angle_urad = static_cast<std::int32_t>(static_cast<std::uint32_t>(urad));
  }
  proto::encode(s, out);
  ++sample_seq_;
  ++stats_.samples_sent;
}

}  // namespace fieldline::world_sim
