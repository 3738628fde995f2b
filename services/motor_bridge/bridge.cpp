#include "services/motor_bridge/bridge.hpp"

#include <algorithm>
#include <cmath>

namespace fieldline::motor_bridge {

namespace proto = serial;

BridgeConfig loadBridgeConfig(const config::Node& root) {
  BridgeConfig c;
  c.device = root.get<std::string>("device");
  c.baud_rate = static_cast<unsigned>(root.get<int>("baud_rate", 1200, 4000000));
  c.reconnect_interval = root.get<double>("reconnect_interval", 0.01, 60.0);
  c.command_rate = root.get<double>("command_rate", 1.0, 1000.0);
  root.rejectUnknownKeys();
  return c;
}

std::string deviceForRobot(const std::string& device, int robot) {
  std::string out = device;
  const std::string key = "{robot}";
  for (auto pos = out.find(key); pos != std::string::npos; pos = out.find(key)) {
    out.replace(pos, key.size(), std::to_string(robot));
  }
  return out;
}

BridgeCore::BridgeCore(const robot::RobotParams& params)
    : params_(params),
      latency_us_(static_cast<Utime>(std::llround(params.controller_latency * 1e6))),
      clock_(ControllerClockMap::Params{.latency_us = latency_us_}),
      odometry_(params) {}

bool BridgeCore::onCommand(const CommandInput& command, Utime now) {
  return commands_.onCommand(command, now);
}

std::vector<std::uint8_t> BridgeCore::commandFrame(Utime now) {
  const CommandInput& current = commands_.due(now);
  proto::VelocityCommand cmd;
  cmd.seq = ++command_seq_;
  if (commands_.hasCommand()) {
    cmd.vx_q15 = proto::toQ15(current.vx);
    cmd.vy_q15 = proto::toQ15(current.vy);
    cmd.omega_q15 = proto::toQ15(current.omega);
  }
  return proto::encode(cmd);
}

std::vector<std::uint8_t> BridgeCore::stopFrame() {
  commands_.clear();
  proto::VelocityCommand cmd;
  cmd.seq = ++command_seq_;
  return proto::encode(cmd);
}

std::vector<std::uint8_t> BridgeCore::helloFrame() const {
  std::vector<std::uint8_t> out{proto::kDelimiter};
  proto::encode(proto::Hello{proto::Role::kHost, 1, 0, 0}, out);
  return out;
}

void BridgeCore::onConnected() {
  // Another controller may answer on the new line: its samples pace nothing until its Hello.
  controller_hello_.reset();
  decoder_.reset();
  last_sample_.reset();
  resync_ = true;
  clock_.reset();
}

void BridgeCore::onBytes(std::span<const std::uint8_t> bytes, Utime now,
                         std::vector<OdometryOutput>& out) {
  messages_.clear();
  const proto::DecoderStats before = decoder_.stats();
  decoder_.feed(bytes, messages_);
  countRejectedFrames(before);
  countControllerMessages();
  checkAndStampSamples(now);
  for (const Checked& c : checked_) {
    const OdometryOutput o = odometryOutput(c);
    last_sample_ = *c.sample;
    out.push_back(o);
  }
}

void BridgeCore::countRejectedFrames(const serial::DecoderStats& before) {
  const proto::DecoderStats& after = decoder_.stats();
  const auto add = [&](proto::Reject reason, std::uint64_t old_count, std::uint64_t new_count) {
    if (new_count > old_count)
      counters_[std::string(proto::rejectName(reason))] += new_count - old_count;
  };
  add(proto::Reject::kCobs, before.cobs_errors, after.cobs_errors);
  add(proto::Reject::kCrc, before.crc_errors, after.crc_errors);
  add(proto::Reject::kLength, before.length_errors, after.length_errors);
  add(proto::Reject::kVersion, before.version_errors, after.version_errors);
  add(proto::Reject::kUnknownType, before.unknown_type_errors, after.unknown_type_errors);
  add(proto::Reject::kOversize, before.oversize_errors, after.oversize_errors);
}

void BridgeCore::countControllerMessages() {
  for (const auto& m : messages_) {
    if (const auto* hello = std::get_if<proto::Hello>(&m)) {
      if (hello->role == proto::Role::kController) {
        controller_hello_ = *hello;
        if (hello->ticks_per_revolution != params_.ticksPerWheelRevolution()) {
          count("controller_ticks_mismatch");
        }
      }
    } else if (const auto* err = std::get_if<proto::ErrorReport>(&m)) {
      count("controller_error_" + std::to_string(static_cast<int>(err->code)));
    } else if (!std::get_if<proto::OdometrySample>(&m)) {
      count("unexpected_message");
    }
  }
}

bool BridgeCore::acceptSample(const serial::OdometrySample& sample,
                              const std::optional<serial::OdometrySample>& last) {
  if (sample.controller_time_us > kMaxControllerTimeUs) {
    count("odometry_controller_time_absurd");  // CRC-valid but no clock runs for 285 years
    return false;
  }
  if (static_cast<int>(sample.ticks.size()) != params_.wheelCount()) {
    // A controller for another robot (or a robot file with the wrong wheels): its ticks mean
    // nothing with this geometry.
    count("odometry_wheel_count_mismatch");
    return false;
  }
  if (last && sample.seq == last->seq && sample.controller_time_us == last->controller_time_us) {
    count("odometry_duplicate");  // the same frame twice (a replaying line)
    return false;
  }
  return true;
}

bool BridgeCore::startsOver(const serial::OdometrySample& sample,
                            const std::optional<serial::OdometrySample>& last) {
  if (resync_ || !last || (sample.status & proto::kStatusReset) != 0) return true;
  const std::uint32_t gap = sample.seq - last->seq;  // wraps like the counter
  // A controller that restarted without us seeing its reset flag: seq or clock jumped back
  // (a huge unsigned gap), stood still, or leapt far ahead. Its ticks no longer continue ours.
  if (gap == 0 || gap > kMaxSampleGap || sample.controller_time_us <= last->controller_time_us) {
    count("odometry_discontinuity");
    return true;
  }
  return false;
}

void BridgeCore::checkAndStampSamples(Utime now) {
  // The bridge's checks first: only samples that pass them feed the clock mapping (a replayed
  // or stale frame must not restart it), and a resync (the reset flag, a discontinuity) starts
  // the mapping over. Every sample of one stretch feeds it before any of the stretch is stamped:
  // samples that arrive together (the bridge was busy) are stamped by their own controller time,
  // and the newest of them carries the read's least delay.
  checked_.clear();
  std::optional<proto::OdometrySample> last = last_sample_;
  std::size_t unstamped = 0;
  const auto stampStretch = [&] {
    for (; unstamped < checked_.size(); ++unstamped) {
      Checked& c = checked_[unstamped];
      c.utime = clock_.stamp(static_cast<std::int64_t>(c.sample->controller_time_us)).value_or(now);
    }
  };
  for (const auto& m : messages_) {
    const auto* sample = std::get_if<proto::OdometrySample>(&m);
    if (!sample || !acceptSample(*sample, last)) continue;
    const bool resync = startsOver(*sample, last);
    resync_ = false;
    if (resync) {
      stampStretch();
      clock_.reset();
    }
    clock_.observe(static_cast<std::int64_t>(sample->controller_time_us), now);
    checked_.push_back({sample, resync, now});
    last = *sample;
  }
  stampStretch();
}

OdometryOutput BridgeCore::odometryOutput(const Checked& c) {
  const proto::OdometrySample* sample = c.sample;
  OdometryOutput o;
  o.utime = c.utime;
  o.ticks.assign(sample->ticks.begin(), sample->ticks.end());
  o.controller_utime = static_cast<std::int64_t>(sample->controller_time_us);
  if (sample->status & proto::kStatusWatchdog) o.status |= perception::kOdometryWatchdog;
  if (sample->status & proto::kStatusMotorFault) o.status |= perception::kOdometryMotorFault;
  if (sample->current_ma) {
    // mA on the wire, A on the bus; any int16 is a finite current (fusion judges the size).
    for (const std::int16_t ma : *sample->current_ma)
      o.wheel_current.push_back(static_cast<float>(ma) * 1e-3f);
    o.status |= perception::kOdometryCurrents;
  }
  if (c.resync) {
    o.status |= perception::kOdometryResync;
    odometry_.reset();
    odometry_.update(sample->ticks);
  } else {
    addMovementSinceLast(*sample, o);
  }
  return o;
}

void BridgeCore::addMovementSinceLast(const serial::OdometrySample& sample, OdometryOutput& o) {
  const std::uint32_t gap = sample.seq - last_sample_->seq;
  if (gap != 1) {
    o.status |= perception::kOdometryFramesLost;
    samples_lost_ += gap - 1;
  }
  o.movement = *odometry_.update(sample.ticks);
  if (sample.gyro_angle_urad && last_sample_->gyro_angle_urad) {
    // The gyro's angle accumulates and wraps like the ticks: the difference modulo 2^32
    // covers lost samples too.
    const auto d =
        static_cast<std::int32_t>(static_cast<std::uint32_t>(*sample.gyro_angle_urad) -
                                  static_cast<std::uint32_t>(*last_sample_->gyro_angle_urad));
    o.gyro_dphi = static_cast<double>(d) * 1e-6;
    o.status |= perception::kOdometryGyro;
  }
  const double dt =
      static_cast<double>(sample.controller_time_us - last_sample_->controller_time_us) * 1e-6;
  o.vx = o.movement.dx / dt;
  o.vy = o.movement.dy / dt;
  o.omega = o.movement.dphi / dt;
  // Wheels cannot turn faster than the motors allow; ticks that say so are corrupt.
  if (std::hypot(o.vx, o.vy) > kImplausibleFactor * params_.max_speed ||
      std::abs(o.omega) > kImplausibleFactor * params_.max_omega) {
    count("odometry_implausible");
    o.movement = {};
    o.vx = o.vy = o.omega = 0.0;
    o.gyro_dphi = 0.0;
    o.status &= ~perception::kOdometryGyro;
    o.status |= perception::kOdometryResync;
    odometry_.reset();
    odometry_.update(sample.ticks);
  }
}

}  // namespace fieldline::motor_bridge
