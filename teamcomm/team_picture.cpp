#include "teamcomm/team_picture.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "common/geometry/geometry.hpp"

namespace fieldline::teamcomm {
namespace {

struct BallCandidate {
  int robot_id;
  Eigen::Vector2d position;
  Eigen::Vector2d velocity;
  Eigen::Matrix2d covariance;
};

double seconds(Utime us) {
  return static_cast<double>(us) * 1e-6;
}

double mahalanobis2(const BallCandidate& a, const BallCandidate& b) {
  const Eigen::Vector2d d = a.position - b.position;
  const Eigen::Matrix2d s = a.covariance + b.covariance;
  return d.dot(s.inverse() * d);
}

// Covariance-weighted mean of `members` (information form).
TeamBallResult fuse(const std::vector<const BallCandidate*>& members) {
  TeamBallResult r;
  Eigen::Matrix2d information = Eigen::Matrix2d::Zero();
  Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
  Eigen::Vector2d weighted_velocity = Eigen::Vector2d::Zero();
  double velocity_weight = 0.0;
  for (const BallCandidate* c : members) {
    const Eigen::Matrix2d inv = c->covariance.inverse();
    information += inv;
    weighted += inv * c->position;
    const double w = 1.0 / c->covariance.trace();
    weighted_velocity += w * c->velocity;
    velocity_weight += w;
    r.used.push_back(c->robot_id);
  }
  r.covariance = information.inverse();
  r.position = r.covariance * weighted;
  r.velocity = weighted_velocity / velocity_weight;
  r.valid = true;
  return r;
}

}  // namespace

TeamPicture::TeamPicture(int own_robot_id, PictureOptions options)
    : own_robot_id_(own_robot_id), options_(options) {
  if (own_robot_id < 1 || own_robot_id > perception::kTeamSize) {
    throw std::invalid_argument("robot id must be 1..6");
  }
}

void TeamPicture::setReport(int robot_id, const Report& report) {
  if (robot_id < 1 || robot_id > perception::kTeamSize) return;
  reports_[static_cast<std::size_t>(robot_id - 1)] = report;
}

void TeamPicture::clear(int robot_id) {
  if (robot_id < 1 || robot_id > perception::kTeamSize) return;
  reports_[static_cast<std::size_t>(robot_id - 1)].reset();
}

const Report* TeamPicture::report(int robot_id) const {
  if (robot_id < 1 || robot_id > perception::kTeamSize) return nullptr;
  const auto& r = reports_[static_cast<std::size_t>(robot_id - 1)];
  return r ? &*r : nullptr;
}

perception::TeamState TeamPicture::picture(Utime now, TeamBallResult* team_ball) const {
  perception::TeamState s;
  s.utime = now;
  std::vector<BallCandidate> candidates;
  for (int i = 0; i < perception::kTeamSize; ++i) {
    const auto& report = reports_[static_cast<std::size_t>(i)];
    perception::TeammateState& out = s.robots[static_cast<std::size_t>(i)];
    if (!report) continue;
    out.present = now - report->received_utime <= options_.present_timeout_us;
    if (!out.present) continue;
    const perception::RobotEstimate& robot = report->robot;
    out.robot_age_us = now - robot.utime;
    const double dt = seconds(std::clamp<Utime>(out.robot_age_us, 0, options_.max_prediction_us));
    out.x = robot.pose.x + robot.vx * dt;
    out.y = robot.pose.y + robot.vy * dt;
    out.phi = geometry::normalizeAngle(robot.pose.phi + robot.omega * dt);
    const double grown = options_.robot_speed_sigma_mps * dt;
    out.twin_ambiguous = robot.twin_ambiguous;
    out.sigma_xy = static_cast<float>(std::sqrt(
        std::max(0.0, 0.5 * (robot.covariance(0, 0) + robot.covariance(1, 1))) + grown * grown));

    const perception::BallEstimate& ball = report->ball;
    const Utime ball_age = now - ball.last_seen_utime;
    // A ball in the field frame is only as good as the pose it was placed with. (A pose flagged
    // as possibly its symmetric twin still gives its ball: at start-up every robot is, and the
    // team confirms the poses with each other's balls; fusion's twin vote weighs the flag.)
    const bool localized = robot.status == perception::LocalizationStatus::kTracking;
    if (!ball.valid || !localized || ball_age > options_.ball_timeout_us) continue;
    out.ball_valid = true;
    out.ball_age_us = ball_age;
    const double ball_dt =
        seconds(std::clamp<Utime>(now - ball.utime, 0, options_.max_prediction_us));
    out.ball_x = ball.x + ball.vx * ball_dt;
    out.ball_y = ball.y + ball.vy * ball_dt;
    BallCandidate c{i + 1, {out.ball_x, out.ball_y}, {ball.vx, ball.vy}, ball.covariance};
    const double grown_ball = options_.ball_speed_sigma_mps * ball_dt;
    c.covariance += Eigen::Matrix2d::Identity() * (grown_ball * grown_ball);
    c.covariance += robot.covariance.topLeftCorner<2, 2>();
    c.covariance = 0.5 * (c.covariance + c.covariance.transpose()).eval();
    c.covariance(0, 0) = std::max(c.covariance(0, 0), options_.min_ball_variance);
    c.covariance(1, 1) = std::max(c.covariance(1, 1), options_.min_ball_variance);
    if (c.covariance.determinant() <= 0.0) {
      c.covariance = Eigen::Matrix2d::Identity() * std::max(c.covariance(0, 0), c.covariance(1, 1));
    }
    candidates.push_back(c);
  }

  // The largest group that agrees with one of its members wins; among equal groups the one whose
  // fused covariance is smallest.
  TeamBallResult best;
  std::size_t best_size = 0;
  for (const BallCandidate& seed : candidates) {
    std::vector<const BallCandidate*> members;
    for (const BallCandidate& other : candidates) {
      if (mahalanobis2(seed, other) <= options_.gate_chi2) members.push_back(&other);
    }
    TeamBallResult fused = fuse(members);
    if (members.size() > best_size ||
        (members.size() == best_size && fused.covariance.trace() < best.covariance.trace())) {
      best = std::move(fused);
      best_size = members.size();
    }
  }
  for (const BallCandidate& c : candidates) {
    if (std::find(best.used.begin(), best.used.end(), c.robot_id) == best.used.end()) {
      best.rejected.push_back(c.robot_id);
    }
  }
  s.team_ball_valid = best.valid;
  if (best.valid) {
    s.team_ball_x = best.position.x();
    s.team_ball_y = best.position.y();
    s.team_ball_vx = best.velocity.x();
    s.team_ball_vy = best.velocity.y();
    s.team_ball_covariance = best.covariance;
  }
  if (team_ball) *team_ball = std::move(best);
  return s;
}

}  // namespace fieldline::teamcomm
