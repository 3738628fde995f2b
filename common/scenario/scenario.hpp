// A simulation scenario (config/scenarios/<name>.yaml): the field, the robots and what each one
// does, opponents, the ball script, kidnaps, serial outages, duration and random seed.
// world_sim plays the world part; each pilot reads its robot's trajectory from the same file.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/config/config.hpp"
#include "common/geometry/geometry.hpp"
#include "common/robot/trajectory.hpp"

namespace fieldline::scenario {

struct RobotSpec {
  // Robot number 1..6.
  int id = 1;
  // Where it stands at t = 0 (field frame). For a figure eight: the path's start.
  geometry::Pose2 start;
  robot::TrajectorySpec trajectory = robot::StandSpec{};
};

// A moving obstacle that follows its own script and cannot be pushed.
struct OpponentSpec {
  geometry::Pose2 start;
  robot::TrajectorySpec trajectory = robot::StandSpec{};
  // Footprint radius [m].
  double radius = 0.25;
};

// At `time` the ball is (optionally) placed at `position` and given `velocity`.
struct BallKick {
  double time = 0.0;
  std::optional<geometry::Vec2> position;
  geometry::Vec2 velocity = geometry::Vec2::Zero();
};

struct BallSpec {
  geometry::Vec2 start = geometry::Vec2::Zero();
  // [m]
  double radius = 0.11;
  // Deceleration by rolling friction [m/s^2].
  double rolling_deceleration = 0.4;
  // Fraction of the normal speed kept in a bounce off the barrier and off robots.
  double restitution = 0.6;
  std::vector<BallKick> kicks;
};

// A robot lifted and put down elsewhere; its wheels do not turn, so odometry misses it.
struct KidnapSpec {
  double time = 0.0;
  int robot = 1;
  geometry::Pose2 pose;
};

// The robot's serial device disappears for `duration` seconds (the firmware emulator closes
// its pseudo-terminal and opens a new one), as when a USB cable is pulled and plugged back.
struct SerialOutageSpec {
  double time = 0.0;
  int robot = 1;
  double duration = 1.0;
};

struct Scenario {
  std::string name;
  // Field preset name or path.
  std::string field = "msl";
  // Robot preset name or path.
  std::string robot = "fu2004";
  // [s]; 0 runs until stopped.
  double duration = 0.0;
  std::uint64_t seed = 1;
  // Physics steps per second (at least 200).
  double physics_rate = 400.0;
  // Scales the robot's slip noise and systematic errors; 0 makes odometry exact.
  double slip_scale = 1.0;
  std::vector<RobotSpec> robots;
  std::vector<OpponentSpec> opponents;
  BallSpec ball;
  std::vector<KidnapSpec> kidnaps;
  std::vector<SerialOutageSpec> serial_outages;

  // The robot with number `id`, or nullptr.
  const RobotSpec* robotById(int id) const;
};

// Reads a scenario file's root map; throws config::Error (file:line: key) on anything wrong.
Scenario loadScenario(const config::Node& root);
// Loads config/scenarios/<name>.yaml (or a path).
Scenario loadScenarioPreset(const std::string& name_or_path);

}  // namespace fieldline::scenario
