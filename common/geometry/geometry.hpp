// Poses, movements and the transforms between the robot frame and the field frame
// (seed section 4.2-4.3, tables 4.2 and 4.3, eq. 4.7-4.14), in the architecture's frames:
//
//   field frame: origin at the centre spot, x toward the opponent goal, y to the left,
//                angles counter-clockwise from +x.
//   robot frame: origin on the floor under the mirror centre, x forward (the heading), y left.
//
// The seed's robot frame has x to the right and y forward; its formulas are translated here, so
// a robot at field pose (x, y, phi) has its forward axis (cos phi, sin phi) and its left axis
// (-sin phi, cos phi) in the field. Example: at (1, 2, 90 deg) the robot point (1, 0), one metre
// ahead, is the field point (1, 3).
//
// Units: metres and radians. Field poses carry phi normalised to (-pi, pi]; movements carry an
// unbounded rotation (several turns are allowed, as in the seed).
#pragma once

#include <Eigen/Core>

namespace fieldline::geometry {

using Vec2 = Eigen::Vector2d;

// A pose: position and heading. As the robot's state it is its pose in the field frame; the same
// struct holds a pose given in some robot frame (see poseRobotToField).
struct Pose2 {
  double x = 0.0;
  double y = 0.0;
  double phi = 0.0;

  Vec2 position() const { return Vec2(x, y); }
};

// A change of pose expressed in the robot frame at the start of the change: translate by
// (dx, dy) along the start's forward/left axes, and turn by dphi (unbounded, counter-clockwise).
// This is what odometry reports between two ticks. The same struct also holds a movement whose
// translation is given in the field frame (see movementRobotToField); the name of the function
// that produced it says which.
struct Movement {
  double dx = 0.0;
  double dy = 0.0;
  double dphi = 0.0;
};

// --- angles ---

// The angle equal to `a` modulo 2*pi in (-pi, pi]. Non-finite input is returned unchanged (NaN).
double normalizeAngle(double a);
// The signed smallest rotation taking b to a: normalizeAngle(a - b), in (-pi, pi].
double angleDiff(double a, double b);
// `v` turned counter-clockwise by `angle`.
Vec2 rotate(const Vec2& v, double angle);
// True if x, y and phi are all finite.
bool isFinite(const Pose2& pose);
bool isFinite(const Movement& movement);

// --- points and vectors (seed eq. 4.7, 4.8, 4.11, 4.12) ---

// A point given in the robot frame of `robot`, expressed in the field frame.
Vec2 pointRobotToField(const Pose2& robot, const Vec2& point_in_robot);
// A field point expressed in the robot frame of `robot`.
Vec2 pointFieldToRobot(const Pose2& robot, const Vec2& point_in_field);
// A free vector (direction, velocity) in the robot frame, expressed in the field frame.
Vec2 vectorRobotToField(const Pose2& robot, const Vec2& vector_in_robot);
// A free vector in the field frame, expressed in the robot frame.
Vec2 vectorFieldToRobot(const Pose2& robot, const Vec2& vector_in_field);

// --- poses (seed eq. 4.9, 4.13) ---

// A pose given in the robot frame of `robot` (e.g. a feature's local pose), in the field frame.
Pose2 poseRobotToField(const Pose2& robot, const Pose2& pose_in_robot);
// A field pose expressed in the robot frame of `robot`.
Pose2 poseFieldToRobot(const Pose2& robot, const Pose2& pose_in_field);
// Composition a * b: the pose b, given in the frame of a, in a's parent frame
// (same as poseRobotToField(a, b)).
Pose2 compose(const Pose2& a, const Pose2& b);
// The inverse: compose(pose, inverse(pose)) is the identity pose.
Pose2 inverse(const Pose2& pose);

// --- movements (seed eq. 4.6, 4.10, 4.14) ---

// The pose reached from `start` after `movement_in_robot` (robot frame at `start`).
Pose2 applyMovement(const Pose2& start, const Movement& movement_in_robot);
// The movement, in the robot frame at `from`, that leads from `from` to `to`. Its dphi is the
// shortest turn, in (-pi, pi]: whole turns cannot be recovered from two poses.
Movement movementBetween(const Pose2& from, const Pose2& to);
// The movement `first` followed by `second` (second given in the robot frame reached after
// first), as one movement in the robot frame at the start. dphi adds up without normalising.
Movement concatenate(const Movement& first, const Movement& second);
// A movement given in the robot frame of `robot` with its translation rotated into the field
// frame (seed table 4.2, "movement"); dphi is unchanged.
Movement movementRobotToField(const Pose2& robot, const Movement& movement_in_robot);
// The inverse of movementRobotToField (seed table 4.3).
Movement movementFieldToRobot(const Pose2& robot, const Movement& movement_in_field);

}  // namespace fieldline::geometry
