#include "common/robot/robot_params.hpp"

#include <cmath>
#include <numbers>

#include "common/robot/omni_kinematics.hpp"

namespace fieldline::robot {
namespace {

PerWheel<double> perWheel(const config::Node& n, const std::string& key, std::size_t wheels,
                          double limit) {
  const auto values = n.getList<double>(key, wheels);
  PerWheel<double> out(wheels, 0.0);
  for (std::size_t i = 0; i < wheels; ++i) {
    if (std::abs(values[i]) > limit) {
      n.fail(key, "element " + std::to_string(i) + " outside [-" + std::to_string(limit) + ", " +
                      std::to_string(limit) + "]");
    }
    out[i] = values[i];
  }
  return out;
}

}  // namespace

WheelSet RobotParams::trueWheels() const {
  WheelSet out = wheels;
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i].radius *= 1.0 + simulation.wheel_radius_error[i];
    out[i].angle += simulation.wheel_angle_error[i];
  }
  return out;
}

RobotParams loadRobotParams(const config::Node& root) {
  RobotParams p;
  p.name = root.get<std::string>("name");
  p.mass = root.get<double>("mass", 0.5, 100.0);
  p.radius = root.get<double>("radius", 0.05, 1.0);
  p.max_speed = root.get<double>("max_speed", 0.1, 10.0);
  p.max_omega = root.get<double>("max_omega", 0.1, 50.0);
  p.controller_latency = root.get<double>("controller_latency", 0.0, 0.5);
  p.odometry_rate = root.get<double>("odometry_rate", 1.0, 1000.0);
  p.watchdog_timeout = root.get<double>("watchdog_timeout", 0.01, 5.0);

  const auto wheels = root.children("wheels");
  if (wheels.size() < kMinWheels || wheels.size() > kMaxWheels) {
    root.fail("wheels", "expected 3 or 4 wheels, found " + std::to_string(wheels.size()));
  }
  for (const auto& w : wheels) {
    WheelGeometry g;
    g.angle = w.get<double>("angle", -2.0 * std::numbers::pi, 2.0 * std::numbers::pi);
    g.distance = w.get<double>("distance", 0.01, 1.0);
    g.radius = w.get<double>("radius", 0.005, 0.5);
    w.rejectUnknownKeys();
    p.wheels.push_back(g);
  }
  // Wheels that cannot produce every body twist (two of three parallel, all on one line) make
  // odometry and the controller's mapping meaningless: refused here, with the file's line.
  if (!wheelLayoutRegular(p.wheels)) {
    root.fail("wheels",
              "singular layout: these wheels cannot produce every body twist (parallel "
              "drive directions or all on one line)");
  }

  const auto enc = root.child("encoder");
  p.pulses_per_motor_revolution = enc.get<int>("pulses_per_motor_revolution", 1, 100000);
  p.gear_ratio = enc.get<int>("gear_ratio", 1, 1000);
  // The serial protocol's Hello carries ticks per wheel turn in 16 bits.
  if (p.ticksPerWheelRevolution() > 65535) {
    enc.fail("gear_ratio", "pulses_per_motor_revolution * gear_ratio = " +
                               std::to_string(p.ticksPerWheelRevolution()) +
                               " ticks per wheel turn exceeds 65535 (the serial protocol's limit)");
  }
  enc.rejectUnknownKeys();

  const auto motor = root.child("motor");
  p.motor.max_wheel_speed = motor.get<double>("max_wheel_speed", 0.1, 20.0);
  p.motor.time_constant = motor.get<double>("time_constant", 0.001, 10.0);
  p.motor.torque_constant =
      motor.getOr<double>("torque_constant", p.motor.torque_constant, 1e-4, 10.0);
  motor.rejectUnknownKeys();

  if (const auto gyro = root.childIf("gyro")) {
    GyroParams& g = p.gyro;
    g.present = true;
    g.sample_rate = gyro->get<double>("sample_rate", 1.0, 100000.0);
    g.bandwidth = gyro->get<double>("bandwidth", 1.0, 50000.0);
    g.noise_density = gyro->get<double>("noise_density", 0.0, 0.1);
    g.bias_sigma = gyro->get<double>("bias_sigma", 0.0, 1.0);
    g.bias_walk = gyro->get<double>("bias_walk", 0.0, 0.1);
    g.scale_sigma = gyro->get<double>("scale_sigma", 0.0, 0.2);
    g.range = gyro->get<double>("range", 1.0, 1000.0);
    g.lsb = gyro->get<double>("lsb", 0.0, 1.0);
    if (g.bandwidth > 0.5 * g.sample_rate) {
      gyro->fail("bandwidth",
                 "must be at most half the sample_rate (" + std::to_string(g.sample_rate) + " Hz)");
    }
    gyro->rejectUnknownKeys();
  }

  const auto sim = root.child("simulation");
  p.simulation.wheel_radius_error = perWheel(sim, "wheel_radius_error", p.wheels.size(), 0.2);
  p.simulation.wheel_angle_error = perWheel(sim, "wheel_angle_error", p.wheels.size(), 0.2);
  p.simulation.slip_noise = sim.get<double>("slip_noise", 0.0, 1.0);
  p.simulation.rotation_noise = sim.get<double>("rotation_noise", 0.0, 1.0);
  p.simulation.collision_rotation_noise = sim.get<double>("collision_rotation_noise", 0.0, 20.0);
  sim.rejectUnknownKeys();

  root.rejectUnknownKeys();
  return p;
}

RobotParams loadRobotPreset(const std::string& name_or_path) {
  return loadRobotParams(config::Node::loadFile(config::resolvePreset("robot", name_or_path)));
}

}  // namespace fieldline::robot
