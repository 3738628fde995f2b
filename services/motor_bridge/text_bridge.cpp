#include "services/motor_bridge/text_bridge.hpp"

#include <cmath>

#include "common/robot/omni_kinematics.hpp"

namespace fieldline::motor_bridge {

TextBridgeCore::TextBridgeCore(const robot::RobotParams& params)
    : params_(params),
      clock_(ControllerClockMap::Params{
          .latency_us = static_cast<Utime>(std::llround(params.controller_latency * 1e6))}),
      odometry_(params) {}

std::string TextBridgeCore::commandLine(Utime now) {
  const CommandInput& c = commands_.due(now);
  return text::formatCommand(c.vx * params_.max_speed, c.vy * params_.max_speed,
                             c.omega * params_.max_omega);
}

std::string TextBridgeCore::stopLine() {
  commands_.clear();
  return text::formatCommand(0.0, 0.0, 0.0);
}

void TextBridgeCore::onConnected() {
  splitter_.reset();
  last_.reset();
  last_checked_.reset();
  resync_ = true;
  clock_.reset();
}

void TextBridgeCore::reject(const std::string& kind, const std::string& what) {
  ++counters_[kind];
  last_error_ = what;
}

void TextBridgeCore::onLine(std::string_view line, Utime now) {
  const text::Line parsed = text::parseLine(line);
  Sample s;
  if (const auto* e = std::get_if<text::LineError>(&parsed)) {
    reject("text_malformed", e->what);
    return;
  }
  if (std::holds_alternative<text::Comment>(parsed)) return;
  if (const auto* t = std::get_if<text::TickLine>(&parsed)) {
    if (static_cast<int>(t->ticks.size()) != params_.wheelCount()) {
      reject("text_wheel_count", std::to_string(t->ticks.size()) + " tick counts, the robot has " +
                                     std::to_string(params_.wheelCount()) + " wheels: '" +
                                     std::string(line) + "'");
      return;
    }
    s.controller_time_us = t->controller_time_us;
    s.ticks.assign(t->ticks.begin(), t->ticks.end());
  } else if (const auto* v = std::get_if<text::VelocityLine>(&parsed)) {
    if (std::hypot(v->vx, v->vy) > kImplausibleFactor * params_.max_speed ||
        std::abs(v->omega) > kImplausibleFactor * params_.max_omega) {
      reject("text_implausible",
             "velocity beyond what the robot can drive: '" + std::string(line) + "'");
      return;
    }
    s.controller_time_us = v->controller_time_us;
    s.vx = v->vx;
    s.vy = v->vy;
    s.omega = v->omega;
  }
  const std::optional<Sample>& last = last_checked_;
  if (last && last->ticks.size() != s.ticks.size()) {
    // O and S lines mixed: there is no difference to take across them.
    reject("text_mixed", "O and S lines mixed: '" + std::string(line) + "'");
    s.resync = true;
  }
  if (last && s.controller_time_us == last->controller_time_us) {
    reject("text_duplicate", "controller time repeated: '" + std::string(line) + "'");
    return;
  }
  // First sample, a controller clock that ran backwards (restart) or leapt: a resync.
  s.resync = s.resync || resync_ || !last || s.controller_time_us < last->controller_time_us ||
             s.controller_time_us - last->controller_time_us > kMaxIntervalUs;
  resync_ = false;
  if (s.resync) {
    // The samples before it are stamped with the mapping they fed; it starts over here.
    for (Sample& p : pending_) {
      if (p.utime == 0) p.utime = clock_.stamp(p.controller_time_us).value_or(now);
    }
    clock_.reset();
  }
  clock_.observe(s.controller_time_us, now);
  pending_.push_back(s);
  last_checked_ = s;
}

void TextBridgeCore::emit(const Sample& s, std::vector<perception::OdometryReading>& out) {
  perception::OdometryReading o;
  o.utime = s.utime;
  o.controller_utime = s.controller_time_us;
  o.ticks.assign(s.ticks.begin(), s.ticks.end());
  if (s.resync) {
    o.status |= perception::kOdometryResync;
    odometry_.reset();
    if (!s.ticks.empty()) odometry_.update(s.ticks);
    if (s.ticks.empty()) {
      o.vx = s.vx;
      o.vy = s.vy;
      o.omega = s.omega;
    }
    last_ = s;
    out.push_back(o);
    return;
  }
  const double dt = static_cast<double>(s.controller_time_us - last_->controller_time_us) * 1e-6;
  if (!s.ticks.empty()) {
    o.movement = *odometry_.update(s.ticks);
    o.vx = o.movement.dx / dt;
    o.vy = o.movement.dy / dt;
    o.omega = o.movement.dphi / dt;
  } else {
    // The mean of the two velocities over the interval, as an arc of constant twist.
    const Eigen::Vector3d integrated =
        0.5 * dt * Eigen::Vector3d(s.vx + last_->vx, s.vy + last_->vy, s.omega + last_->omega);
    o.movement = robot::arcMovement(integrated);
    o.vx = s.vx;
    o.vy = s.vy;
    o.omega = s.omega;
  }
  if (std::hypot(o.vx, o.vy) > kImplausibleFactor * params_.max_speed ||
      std::abs(o.omega) > kImplausibleFactor * params_.max_omega) {
    // Ticks no wheel can turn in this time: corrupt. Start over from this sample.
    reject("text_implausible", "ticks imply " + std::to_string(std::hypot(o.vx, o.vy)) + " m/s");
    o.movement = {};
    o.vx = o.vy = o.omega = 0.0;
    o.status |= perception::kOdometryResync;
    odometry_.reset();
    if (!s.ticks.empty()) odometry_.update(s.ticks);
  }
  last_ = s;
  out.push_back(o);
}

void TextBridgeCore::onBytes(std::span<const std::uint8_t> bytes, Utime now,
                             std::vector<perception::OdometryReading>& out) {
  pending_.clear();
  splitter_.feed(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                 [&](std::string_view line) { onLine(line, now); });
  if (splitter_.overlong() > overlong_reported_) {
    counters_["text_overlong"] += splitter_.overlong() - overlong_reported_;
    overlong_reported_ = splitter_.overlong();
    last_error_ = "a line longer than " + std::to_string(text::kMaxLineLength) + " characters";
  }
  // Every sample of one read fed the clock mapping before any is stamped (samples read together
  // after a stall keep their own times).
  for (Sample& s : pending_) {
    if (s.utime == 0) s.utime = clock_.stamp(s.controller_time_us).value_or(now);
    emit(s, out);
  }
}

}  // namespace fieldline::motor_bridge
