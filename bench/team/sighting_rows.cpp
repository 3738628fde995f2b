#include "bench/team/sighting_rows.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Core>

#include "common/geometry/geometry.hpp"

namespace fieldline::team_bench {

SightingRows::SightingRows(const std::string& path) {
  if (path.empty()) return;
  file_ = std::fopen(path.c_str(), "w");
  if (file_) {
    std::fputs(
        "robot,t,range,true_range,radial_err,tangential_err,sigma_radial,sigma_tangential,"
        "ball_speed,turn_radps,robot_speed,bearing_rate,occlusion_gap,pose_heading_err\n",
        file_);
  }
}

void SightingRows::close() {
  if (file_) std::fclose(file_);
  file_ = nullptr;
}

void SightingRows::addWorld(const world_state_t& w) {
  if (!file_) return;
  std::vector<Body>& bodies = bodies_[w.header.utime];
  for (int k = 0; k < w.num_robots; ++k) {
    bodies.push_back({w.robot_id[k], w.robot_x[k], w.robot_y[k],
                      w.robot_radius > 0.0f ? static_cast<double>(w.robot_radius) : 0.25});
  }
  for (int k = 0; k < w.num_opponents; ++k) {
    bodies.push_back(
        {0, w.opponent_x[k], w.opponent_y[k], static_cast<double>(w.opponent_radius[k])});
  }
}

double SightingRows::occlusionGap(Utime t, int id, const eval::TruthRobot& robot, double bx,
                                  double by) const {
  const auto it = bodies_.lower_bound(t);
  if (it == bodies_.end()) return std::numeric_limits<double>::infinity();
  const double ball_range = std::hypot(bx - robot.x, by - robot.y);
  const double ball_bearing = std::atan2(by - robot.y, bx - robot.x);
  const double ball_half = std::asin(std::min(1.0, 0.11 / std::max(ball_range, 0.12)));
  double gap = std::numeric_limits<double>::infinity();
  for (const Body& b : it->second) {
    if (b.id == id) continue;
    const double d = std::hypot(b.x - robot.x, b.y - robot.y);
    if (d >= ball_range || d <= b.radius) continue;
    const double sep =
        std::abs(geometry::angleDiff(std::atan2(b.y - robot.y, b.x - robot.x), ball_bearing));
    gap = std::min(gap, sep - std::asin(b.radius / d) - ball_half);
  }
  return gap;
}

void SightingRows::write(const std::vector<eval::TruthSample>& truth, int id,
                         const perception::BallSighting& b,
                         const perception::RobotEstimate* pose_near) {
  eval::TruthRobot tr;
  double bx = 0, by = 0, bx2 = 0, by2 = 0;
  if (!file_ || !b.visible || !eval::truthAt(truth, b.utime, id, tr, &bx, &by)) return;
  eval::truthAt(truth, b.utime + 100'000, id, tr, &bx2, &by2);
  eval::TruthRobot later;  // the robot 20 ms later: its turn rate and speed at the exposure
  eval::truthAt(truth, b.utime + 20'000, id, later, &bx, &by);
  eval::truthAt(truth, b.utime, id, tr, &bx, &by);
  // The true ball in the robot frame at the exposure.
  const double c = std::cos(tr.phi), sn = std::sin(tr.phi);
  const Eigen::Vector2d rel(c * (bx - tr.x) + sn * (by - tr.y),
                            -sn * (bx - tr.x) + c * (by - tr.y));
  const Eigen::Vector2d seen(b.x, b.y);
  const Eigen::Vector2d radial = rel.normalized();
  const Eigen::Vector2d tangential(-radial.y(), radial.x());
  // The ball's true bearing rate in the robot frame (central difference over 20 ms).
  eval::TruthRobot r0, r1;
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  double bearing_rate = std::numeric_limits<double>::quiet_NaN();
  if (eval::truthAt(truth, b.utime - 10'000, id, r0, &x0, &y0) &&
      eval::truthAt(truth, b.utime + 10'000, id, r1, &x1, &y1)) {
    bearing_rate = geometry::angleDiff(std::atan2(y1 - r1.y, x1 - r1.x) - r1.phi,
                                       std::atan2(y0 - r0.y, x0 - r0.x) - r0.phi) /
                   0.02;
  }
  // Fusion's heading at the exposure: the nearest ROBOT_STATE carried there with its turn rate.
  double heading_err = std::numeric_limits<double>::quiet_NaN();
  if (pose_near) {
    const double dt = static_cast<double>(b.utime - pose_near->utime) * 1e-6;
    heading_err = geometry::angleDiff(pose_near->pose.phi + pose_near->omega * dt, tr.phi);
  }
  std::fprintf(file_, "%d,%.3f,%.3f,%.3f,%.4f,%.4f,%.4f,%.4f,%.3f,%.3f,%.3f,%.4f,%.4f,%.4f\n", id,
               static_cast<double>(b.utime - truth.front().utime) / 1e6, seen.norm(), rel.norm(),
               (seen - rel).dot(radial), (seen - rel).dot(tangential), b.sigma_radial,
               b.sigma_tangential, std::hypot(bx2 - bx, by2 - by) / 0.1,
               geometry::normalizeAngle(later.phi - tr.phi) / 0.02,
               std::hypot(later.x - tr.x, later.y - tr.y) / 0.02, bearing_rate,
               occlusionGap(b.utime, id, tr, bx, by), heading_err);
}

}  // namespace fieldline::team_bench
