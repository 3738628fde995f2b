// The simulated world: own robots with the seed's omni drive and motor model, scripted
// opponents, a ball, the barrier around the field. Physics at the scenario's rate (>= 200 Hz),
// deterministic for a scenario seed. No clock, no I/O: step() advances simulated time.
//
// Each robot's wheels follow their commands through the motor model (seed eq. 4.45); the
// encoders count the wheels' rotation. The ground moves the body by the true geometry (wheel
// radii and axis angles off by the robot config's systematic errors), with random slip on every
// wheel, and not at all into obstacles: in a collision the wheels keep turning while the body is
// stopped and twisted, which odometry cannot see. Kidnaps move a robot without turning a wheel.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "common/robot/motor_model.hpp"
#include "common/robot/omni_kinematics.hpp"
#include "common/robot/robot_params.hpp"
#include "common/robot/trajectory.hpp"
#include "common/robot/wheel_odometry.hpp"
#include "common/scenario/scenario.hpp"

namespace fieldline::world_sim {

struct WorldSnapshot;

struct RobotTruth {
  int id = 1;
  // Field frame.
  geometry::Pose2 pose;
  // [m/s] field frame, [rad/s].
  geometry::Vec2 velocity = geometry::Vec2::Zero();
  double omega = 0.0;
  // One value per wheel of the robot (sized by the World). Normalised wheel commands in [-1, 1]
  // the motors currently act on.
  robot::WheelVector wheel_commands;
  // Wheel speed as the encoders see it: angular speed times the nominal radius [m/s].
  robot::WheelVector wheel_speeds;
  // Total wheel rotation since the start [rad], what the encoders count.
  robot::WheelVector wheel_angles;
  // Total slip of each wheel since the start [m]: its true surface travel minus the body's
  // ground travel at the wheel along its rolling direction (after collisions). Grows with the
  // slip noise while driving and fast while another robot pushes or twists the body. An output
  // for the controller's current model (firmware.hpp); the motion does not depend on it.
  robot::WheelVector wheel_slip;
  int kidnaps = 0;
  // Collision steps so far (barrier, robots, opponents, ball).
  std::int64_t contact_steps = 0;
  bool in_contact = false;
};

struct OpponentTruth {
  geometry::Pose2 pose;
  double radius = 0.25;
};

struct BallTruth {
  geometry::Vec2 position = geometry::Vec2::Zero();
  geometry::Vec2 velocity = geometry::Vec2::Zero();
  double radius = 0.11;
};

class World {
 public:
  // Robot parameters and field from the scenario's presets unless given.
  explicit World(const scenario::Scenario& scenario);
  World(const scenario::Scenario& scenario, const robot::RobotParams& params,
        const field::FieldModel& field);

  // Sets what robot `index`'s motors act on from now: normalised wheel commands in [-1, 1]
  // (non-finite values stop the wheel).
  void setWheelCommands(std::size_t index, const robot::WheelVector& commands);
  // The same through the controller's mapping of a normalised body command (robot/motor_model).
  void setCommand(std::size_t index, const robot::NormalizedCommand& command);

  // Advances one physics step; applies the scenario's kicks and kidnaps that fall due.
  void step();
  // Steps until time() >= t.
  void runUntil(double t);
  // Simulated seconds since the start.
  double time() const { return static_cast<double>(steps_) * dt_; }
  // Length of one physics step, s.
  double stepSeconds() const { return dt_; }
  double stepSize() const { return dt_; }
  std::int64_t steps() const { return steps_; }

  const std::vector<RobotTruth>& robots() const { return robots_; }
  const std::vector<OpponentTruth>& opponents() const { return opponents_; }
  const BallTruth& ball() const { return ball_; }
  // Index of robot number `id`, or -1.
  int indexOf(int id) const;
  // Accumulated encoder ticks of robot `index` (floor of rotation * ticks per turn / 2 pi),
  // wrapping as int32 like the controller's counters.
  robot::TickCounts ticks(std::size_t index) const;
  // Lifts robot `index` and puts it down at `pose`; the wheels do not turn.
  void kidnap(std::size_t index, const geometry::Pose2& pose);

  // The state that a later restore() continues from (world_snapshot.hpp); saved_utime is left 0.
  WorldSnapshot snapshot() const;
  // Continues from `snapshot` (taken of the same scenario): time, robots, ball, opponents,
  // pending events, the random engine. Throws std::invalid_argument when it does not fit this
  // world (another scenario, other robots, events out of range).
  void restore(const WorldSnapshot& snapshot);

  const scenario::Scenario& scenario() const { return scenario_; }
  const robot::RobotParams& robotParams() const { return params_; }
  const field::FieldModel& field() const { return field_; }

 private:
  void stepRobot(std::size_t index);
  void resolveCollisions();
  void stepBall();
  void applyEvents();

  scenario::Scenario scenario_;
  robot::RobotParams params_;
  field::FieldModel field_;
  double dt_;
  std::int64_t steps_ = 0;
  robot::OmniKinematics nominal_;
  robot::OmniKinematics true_;
  robot::MotorModel motor_;
  robot::WheelVector radius_scale_;
  geometry::Vec2 barrier_;
  std::vector<RobotTruth> robots_;
  std::vector<geometry::Pose2> previous_poses_;
  // Each robot's true wheel surface travel in the current step [m].
  std::vector<robot::WheelVector> surface_travel_;
  std::vector<OpponentTruth> opponents_;
  std::vector<robot::Trajectory> opponent_paths_;
  BallTruth ball_;
  std::size_t next_kick_ = 0;
  std::size_t next_kidnap_ = 0;
  std::vector<scenario::BallKick> kicks_;
  std::vector<scenario::KidnapSpec> kidnaps_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
};

}  // namespace fieldline::world_sim
