#include "common/geometry/geometry.hpp"

#include <cmath>
#include <numbers>

namespace fieldline::geometry {

double normalizeAngle(double a) {
  if (!std::isfinite(a)) return a;
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  // remainder() gives [-pi, pi]; fold -pi onto +pi for the half-open interval.
  double r = std::remainder(a, kTwoPi);
  if (r <= -std::numbers::pi) r += kTwoPi;
  return r;
}

double angleDiff(double a, double b) {
  return normalizeAngle(a - b);
}

Vec2 rotate(const Vec2& v, double angle) {
  const double c = std::cos(angle);
  const double s = std::sin(angle);
  return Vec2(c * v.x() - s * v.y(), s * v.x() + c * v.y());
}

bool isFinite(const Pose2& pose) {
  return std::isfinite(pose.x) && std::isfinite(pose.y) && std::isfinite(pose.phi);
}

bool isFinite(const Movement& movement) {
  return std::isfinite(movement.dx) && std::isfinite(movement.dy) && std::isfinite(movement.dphi);
}

Vec2 pointRobotToField(const Pose2& robot, const Vec2& point_in_robot) {
  return robot.position() + rotate(point_in_robot, robot.phi);
}

Vec2 pointFieldToRobot(const Pose2& robot, const Vec2& point_in_field) {
  return rotate(point_in_field - robot.position(), -robot.phi);
}

Vec2 vectorRobotToField(const Pose2& robot, const Vec2& vector_in_robot) {
  return rotate(vector_in_robot, robot.phi);
}

Vec2 vectorFieldToRobot(const Pose2& robot, const Vec2& vector_in_field) {
  return rotate(vector_in_field, -robot.phi);
}

Pose2 poseRobotToField(const Pose2& robot, const Pose2& pose_in_robot) {
  const Vec2 p = pointRobotToField(robot, pose_in_robot.position());
  return {p.x(), p.y(), normalizeAngle(robot.phi + pose_in_robot.phi)};
}

Pose2 poseFieldToRobot(const Pose2& robot, const Pose2& pose_in_field) {
  const Vec2 p = pointFieldToRobot(robot, pose_in_field.position());
  return {p.x(), p.y(), normalizeAngle(pose_in_field.phi - robot.phi)};
}

Pose2 compose(const Pose2& a, const Pose2& b) {
  return poseRobotToField(a, b);
}

Pose2 inverse(const Pose2& pose) {
  return poseFieldToRobot(pose, Pose2{});
}

Pose2 applyMovement(const Pose2& start, const Movement& movement_in_robot) {
  const Vec2 p = pointRobotToField(start, Vec2(movement_in_robot.dx, movement_in_robot.dy));
  return {p.x(), p.y(), normalizeAngle(start.phi + movement_in_robot.dphi)};
}

Movement movementBetween(const Pose2& from, const Pose2& to) {
  const Vec2 d = pointFieldToRobot(from, to.position());
  return {d.x(), d.y(), angleDiff(to.phi, from.phi)};
}

Movement concatenate(const Movement& first, const Movement& second) {
  const Vec2 t = Vec2(first.dx, first.dy) + rotate(Vec2(second.dx, second.dy), first.dphi);
  return {t.x(), t.y(), first.dphi + second.dphi};
}

Movement movementRobotToField(const Pose2& robot, const Movement& movement_in_robot) {
  const Vec2 t = rotate(Vec2(movement_in_robot.dx, movement_in_robot.dy), robot.phi);
  return {t.x(), t.y(), movement_in_robot.dphi};
}

Movement movementFieldToRobot(const Pose2& robot, const Movement& movement_in_field) {
  const Vec2 t = rotate(Vec2(movement_in_field.dx, movement_in_field.dy), -robot.phi);
  return {t.x(), t.y(), movement_in_field.dphi};
}

}  // namespace fieldline::geometry
