// Scripted reference motions for a robot (the pilot's trajectories and the simulator's tests),
// all in the field frame, and a tracking law that turns a reference and a measured pose into a
// normalised motion command.
#pragma once

#include <cstdint>
#include <variant>
#include <vector>

#include "common/geometry/geometry.hpp"
#include "common/robot/motor_model.hpp"
#include "common/robot/robot_params.hpp"

namespace fieldline::robot {

// Where the robot should be at a time, and how it should be moving there (field frame).
struct TrajectorySample {
  geometry::Pose2 pose;
  // [m/s], field frame.
  geometry::Vec2 velocity = geometry::Vec2::Zero();
  // [rad/s]
  double omega = 0.0;
};

// A figure eight (lemniscate of Gerono) through `center`, driven at constant speed with the
// heading along the path (seed 4.14 drives one at 0.8 m/s). Its long axis makes `rotation`
// with the field x axis; it starts at the centre heading into the upper-right lobe.
struct FigureEightSpec {
  geometry::Vec2 center = geometry::Vec2::Zero();
  // Extent along the long axis and across it [m].
  double length = 6.0;
  double width = 3.0;
  // [rad]
  double rotation = 0.0;
  // Path speed [m/s].
  double speed = 0.8;
};

// Straight legs between points at constant speed, heading along the leg (or held at the start
// heading when face_along_path is false). Without loop the robot stops at the last point.
struct WaypointSpec {
  std::vector<geometry::Vec2> points;
  double speed = 1.0;
  bool loop = true;
  bool face_along_path = true;
};

// Turning on the spot at the start position.
struct RotateSpec {
  double omega = 1.0;
};

// Holding the start pose.
struct StandSpec {};

// A tour through random points of a rectangle around the field centre, deterministic for a seed.
struct RandomPlaySpec {
  double half_length = 4.0;
  double half_width = 2.5;
  double speed = 1.5;
  std::uint64_t seed = 1;
};

using TrajectorySpec =
    std::variant<FigureEightSpec, WaypointSpec, RotateSpec, StandSpec, RandomPlaySpec>;

class Trajectory {
 public:
  // `start` is where the robot stands at t = 0: waypoint tours and random play begin there,
  // rotation and standing keep its position. A figure eight ignores it (see startPose()).
  Trajectory(const TrajectorySpec& spec, const geometry::Pose2& start);

  // The reference at `t` seconds after the start (t < 0 gives the start).
  TrajectorySample at(double t) const;
  // The pose the reference has at t = 0.
  geometry::Pose2 startPose() const { return at(0.0).pose; }

 private:
  struct Leg {
    geometry::Vec2 from;
    geometry::Vec2 to;
    double t0 = 0.0;
    double duration = 0.0;
  };
  TrajectorySample figureEightAt(double t) const;
  TrajectorySample legsAt(double t) const;
  void buildLegs(const std::vector<geometry::Vec2>& points, double speed, bool loop);

  TrajectorySpec spec_;
  geometry::Pose2 start_;
  // Figure eight: path parameter at equally spaced arc lengths, for constant speed.
  std::vector<double> arc_parameter_;
  double perimeter_ = 0.0;
  // Waypoint tours and random play.
  std::vector<Leg> legs_;
  double loop_period_ = 0.0;
  bool face_along_path_ = true;
};

// Gains of the tracking law: field velocity = reference velocity + position_gain * error
// (the correction limited to max_correction_speed), omega = reference omega + heading_gain *
// heading error.
struct FollowerGains {
  // [1/s]
  double position_gain = 2.0;
  // [1/s]
  double heading_gain = 3.0;
  // [m/s]
  double max_correction_speed = 1.0;
};

// The normalised command that steers a robot at `measured` toward `reference`.
NormalizedCommand followTrajectory(const TrajectorySample& reference,
                                   const geometry::Pose2& measured, const RobotParams& params,
                                   const FollowerGains& gains = {});

}  // namespace fieldline::robot
