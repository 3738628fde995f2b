#include "teamcomm/team_picture.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <tuple>

#include "common/geometry/geometry.hpp"

namespace fieldline::teamcomm {
namespace {

double seconds(Utime us) {
  return static_cast<double>(us) * 1e-6;
}

double mahalanobis2(const Eigen::Vector2d& a, const Eigen::Matrix2d& ca, const Eigen::Vector2d& b,
                    const Eigen::Matrix2d& cb) {
  const Eigen::Vector2d d = a - b;
  const Eigen::Matrix2d s = ca + cb;
  return d.dot(s.inverse() * d);
}

double mahalanobis2(const BallCandidate& a, const BallCandidate& b) {
  return mahalanobis2(a.position, a.covariance, b.position, b.covariance);
}

// The part of a candidate's covariance that is its own: without the stamp term that every
// BALL_STATE carries (fusion's ball.stamp_sigma_s times the velocity, along it), which is common
// to the reporters. Its smallest variance is kept at `min_variance`.
Eigen::Matrix2d ownPart(const BallCandidate& c, double stamp2, double min_variance) {
  const Eigen::Matrix2d own = c.covariance - stamp2 * c.velocity * c.velocity.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(0.5 * (own + own.transpose()));
  const Eigen::Vector2d values = eig.eigenvalues().cwiseMax(min_variance);
  return eig.eigenvectors() * values.asDiagonal() * eig.eigenvectors().transpose();
}

// Covariance-weighted mean of `members` (information form), weighted by their own parts
// (ownPart): the stamp term is common to them, so it neither shrinks by fusing nor says which
// reporter sees the ball better (a rolling ball's 6 cm along its velocity at 2 m/s made a robot
// 1-2 m away, 1-2 cm off, weigh as much as one 4-5 m away, 5 cm off). The fused covariance holds
// the stamp term once, at the fused velocity.
TeamBallResult fuse(const std::vector<const BallCandidate*>& members, double stamp_sigma_s,
                    double min_variance) {
  TeamBallResult r;
  const double stamp2 = stamp_sigma_s * stamp_sigma_s;
  Eigen::Matrix2d information = Eigen::Matrix2d::Zero();
  Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
  Eigen::Vector2d weighted_velocity = Eigen::Vector2d::Zero();
  double velocity_weight = 0.0;
  for (const BallCandidate* c : members) {
    const Eigen::Matrix2d own = ownPart(*c, stamp2, min_variance);
    const Eigen::Matrix2d inv = own.inverse();
    information += inv;
    weighted += inv * c->position;
    const double w = 1.0 / own.trace();
    weighted_velocity += w * c->velocity;
    velocity_weight += w;
    r.used.push_back(c->robot_id);
  }
  const Eigen::Matrix2d fused = information.inverse();
  r.position = fused * weighted;
  r.velocity = weighted_velocity / velocity_weight;
  r.covariance = fused + stamp2 * r.velocity * r.velocity.transpose();
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

namespace {

// Whether `c` lies at the mirror image of the track (through the centre spot) and not at it.
bool atMirrorImageOf(const BallCandidate& c, const BallCandidate& track, double gate_chi2) {
  return mahalanobis2(-c.position, c.covariance, track.position, track.covariance) <= gate_chi2 &&
         mahalanobis2(c.position, c.covariance, track.position, track.covariance) > gate_chi2;
}

}  // namespace

std::optional<BallCandidate> TeamPicture::updateTeammate(const Report& report, Utime now,
                                                         perception::TeammateState& out) const {
  out.present = now - report.received_utime <= options_.present_timeout_us;
  if (!out.present) return std::nullopt;
  const perception::RobotEstimate& robot = report.robot;
  out.robot_age_us = now - robot.utime;
  const double dt = seconds(std::clamp<Utime>(out.robot_age_us, 0, options_.max_prediction_us));
  out.x = robot.pose.x + robot.vx * dt;
  out.y = robot.pose.y + robot.vy * dt;
  out.phi = geometry::normalizeAngle(robot.pose.phi + robot.omega * dt);
  const double grown = options_.robot_speed_sigma_mps * dt;
  out.twin_ambiguous = robot.twin_ambiguous;
  out.sigma_xy = static_cast<float>(std::sqrt(
      std::max(0.0, 0.5 * (robot.covariance(0, 0) + robot.covariance(1, 1))) + grown * grown));

  const perception::BallEstimate& ball = report.ball;
  const Utime ball_age = now - ball.last_seen_utime;
  // A ball in the field frame is only as good as the pose it was placed with. (A pose flagged
  // as possibly its symmetric twin still gives its ball: at start-up every robot is, and the
  // team confirms the poses with each other's balls; fusion's twin vote weighs the flag.)
  const bool localized = robot.status == perception::LocalizationStatus::kTracking;
  if (!ball.valid || !localized || ball_age > options_.ball_timeout_us) return std::nullopt;
  out.ball_valid = true;
  out.ball_age_us = ball_age;
  const double ball_dt =
      seconds(std::clamp<Utime>(now - ball.utime, 0, options_.max_prediction_us));
  out.ball_x = ball.x + ball.vx * ball_dt;
  out.ball_y = ball.y + ball.vy * ball_dt;
  return ballCandidate(report, {out.ball_x, out.ball_y}, {out.x, out.y}, ball_dt);
}

BallCandidate TeamPicture::ballCandidate(const Report& report, const Eigen::Vector2d& position,
                                         const Eigen::Vector2d& reporter, double ball_dt) const {
  const perception::BallEstimate& ball = report.ball;
  BallCandidate c{0,
                  position,
                  {ball.vx, ball.vy},
                  ball.covariance,
                  report.robot.twin_ambiguous,
                  ball.last_seen_utime};
  const bool resting = std::hypot(ball.vx, ball.vy) < options_.ball_rest_speed_mps;
  const double grown_ball =
      (resting ? options_.ball_rest_speed_sigma_mps : options_.ball_speed_sigma_mps) * ball_dt;
  c.covariance += Eigen::Matrix2d::Identity() * (grown_ball * grown_ball);
  // The bias a static view keeps along its line of sight (PictureOptions).
  const Eigen::Vector2d line_of_sight = position - reporter;
  const perception::RobotEstimate& robot = report.robot;
  const bool static_view = resting && std::hypot(robot.vx, robot.vy) < options_.static_speed_mps &&
                           std::abs(robot.omega) < options_.static_turn_radps;
  if (static_view && options_.ball_radial_floor_per_m2 > 0.0 && line_of_sight.norm() > 0.0) {
    const Eigen::Vector2d along = line_of_sight.normalized();
    const double floor = options_.ball_radial_floor_per_m2 * line_of_sight.squaredNorm();
    const double radial = along.dot(c.covariance * along);
    if (radial < floor * floor)
      c.covariance += (floor * floor - radial) * along * along.transpose();
  }
  // The reporter's pose uncertainty is in the ball's covariance already: fusion's ball filter
  // carries it into the field frame with every sighting (position, and heading times the
  // distance). Adding it here again made the team ball worse (replays of four recorded
  // scenarios, docs/teamcomm.md "Team ball").
  c.covariance = 0.5 * (c.covariance + c.covariance.transpose()).eval();
  c.covariance(0, 0) = std::max(c.covariance(0, 0), options_.min_ball_variance);
  c.covariance(1, 1) = std::max(c.covariance(1, 1), options_.min_ball_variance);
  if (c.covariance.determinant() <= 0.0) {
    c.covariance = Eigen::Matrix2d::Identity() * std::max(c.covariance(0, 0), c.covariance(1, 1));
  }
  return c;
}

// Balls contradicted by a sighting made well after their own last one: the ball has moved since
// (kicked, put back), their reporters have not seen it since. Left out before grouping, so that
// two stale reporters cannot outvote the one that sees where the ball is now.
std::vector<int> TeamPicture::leaveOutSuperseded(std::vector<BallCandidate>& candidates) const {
  std::vector<int> superseded;
  if (options_.superseded_after_us <= 0) return superseded;
  std::vector<BallCandidate> current;
  const double max_variance = options_.supersede_max_sigma_m * options_.supersede_max_sigma_m;
  for (const BallCandidate& c : candidates) {
    const bool stale = std::any_of(candidates.begin(), candidates.end(), [&](const auto& d) {
      const bool confident = d.covariance.eigenvalues().real().maxCoeff() <= max_variance;
      return confident && d.last_seen - c.last_seen > options_.superseded_after_us &&
             mahalanobis2(c, d) > options_.gate_chi2;
    });
    if (stale) {
      superseded.push_back(c.robot_id);
    } else {
      current.push_back(c);
    }
  }
  candidates = std::move(current);
  return superseded;
}

std::optional<BallCandidate> TeamPicture::trackAt(Utime now) const {
  if (!track_ || now < track_->utime || now - track_->utime > options_.track_timeout_us) {
    return std::nullopt;
  }
  const double dt = seconds(std::min<Utime>(now - track_->utime, options_.max_prediction_us));
  const double grown = options_.ball_speed_sigma_mps * dt;
  return BallCandidate{0, track_->position + track_->velocity * dt, track_->velocity,
                       track_->covariance + Eigen::Matrix2d::Identity() * (grown * grown)};
}

namespace {

// Covariance intersection of two estimates whose errors may be correlated in any way: the
// information-weighted mean with weights w and 1 - w, w chosen for the smallest trace. Never
// more confident than the better of the two; either one alone when it is better in every
// direction. The weight of `a` (0: b alone).
double intersect(const Eigen::Vector2d& a, const Eigen::Matrix2d& ca, Eigen::Vector2d& b,
                 Eigen::Matrix2d& cb) {
  const Eigen::Matrix2d ia = ca.inverse(), ib = cb.inverse();
  double best_w = 0.0, best_trace = cb.trace();
  for (int i = 1; i <= 20; ++i) {
    const double w = 0.05 * i;
    const double trace = (w * ia + (1.0 - w) * ib).inverse().trace();
    if (trace < best_trace) {
      best_trace = trace;
      best_w = w;
    }
  }
  if (best_w == 0.0) return 0.0;
  cb = (best_w * ia + (1.0 - best_w) * ib).inverse();
  b = cb * (best_w * ia * a + (1.0 - best_w) * ib * b);
  return best_w;
}

}  // namespace

std::vector<int> TeamPicture::carryTrack(Utime now, TeamBallResult& best) const {
  std::vector<int> used = best.used;
  std::sort(used.begin(), used.end());
  if (!options_.carry_track || !track_ || now < track_->utime ||
      now - track_->utime > options_.ball_timeout_us) {
    return used;
  }
  // Only what the group does not hold already: a reporter's newer estimate has its older ones in
  // it (its filter), and carrying them again would keep an early, overconfident one.
  if (std::includes(used.begin(), used.end(), track_->sources.begin(), track_->sources.end())) {
    return used;
  }
  // Only a resting ball: a rolling one's carried velocity lags a kick or a bounce.
  if (track_->velocity.norm() >= options_.ball_rest_speed_mps ||
      best.velocity.norm() >= options_.ball_rest_speed_mps) {
    return used;
  }
  const double dt = seconds(std::min<Utime>(now - track_->utime, options_.max_prediction_us));
  const double grown = options_.carry_speed_sigma_mps * dt;
  const Eigen::Matrix2d carried_covariance =
      track_->covariance + Eigen::Matrix2d::Identity() * (grown * grown);
  if (mahalanobis2(track_->position, carried_covariance, best.position, best.covariance) >
      options_.gate_chi2) {
    return used;
  }
  const double w = intersect(track_->position, carried_covariance, best.position, best.covariance);
  if (w == 0.0) return used;
  if (w == 1.0) return track_->sources;
  std::vector<int> both;
  std::set_union(used.begin(), used.end(), track_->sources.begin(), track_->sources.end(),
                 std::back_inserter(both));
  return both;
}

// Every group that agrees with one of its members. The largest wins; among equal ones, the one
// that continues the previous team ball, then the one with fewer reporters whose pose may be its
// twin, then the one whose fused covariance is smallest.
TeamPicture::Choice TeamPicture::largestConsistentGroup(
    const std::vector<BallCandidate>& candidates, const std::optional<BallCandidate>& track) const {
  const auto agreesWithTrack = [&](const TeamBallResult& r) {
    return track && mahalanobis2(r.position, r.covariance, track->position, track->covariance) <=
                        options_.gate_chi2;
  };
  Choice best;
  int best_ambiguous = 0;
  for (const BallCandidate& seed : candidates) {
    std::vector<const BallCandidate*> members;
    int ambiguous = 0;
    for (const BallCandidate& other : candidates) {
      if (mahalanobis2(seed, other) <= options_.gate_chi2) {
        members.push_back(&other);
        ambiguous += other.twin_ambiguous ? 1 : 0;
      }
    }
    TeamBallResult fused = fuse(members, options_.ball_stamp_sigma_s, options_.min_ball_variance);
    const bool continues = agreesWithTrack(fused);
    const auto rank = std::make_tuple(members.size(), continues, -ambiguous);
    const auto best_rank = std::make_tuple(best.size, best.continues, -best_ambiguous);
    if (rank > best_rank ||
        (rank == best_rank && fused.covariance.trace() < best.ball.covariance.trace())) {
      best.ball = std::move(fused);
      best.size = members.size();
      best.continues = continues;
      best_ambiguous = ambiguous;
    }
  }
  return best;
}

// A lone group that lies at the mirror image of the previous team ball and not at it: its
// reporters are on their twins (a kidnap continuity cannot resolve); none of it is used.
// Every candidate not used is rejected (and said to be mirrored when it lies at the mirror image).
void TeamPicture::rejectTheOthers(Choice& choice, const std::vector<BallCandidate>& candidates,
                                  const std::optional<BallCandidate>& track,
                                  const std::vector<int>& superseded) const {
  TeamBallResult& best = choice.ball;
  const bool mirrored = best.valid && choice.size == 1 && track && !choice.continues &&
                        mahalanobis2(-best.position, best.covariance, track->position,
                                     track->covariance) <= options_.gate_chi2;
  for (const BallCandidate& c : candidates) {
    if (mirrored || std::find(best.used.begin(), best.used.end(), c.robot_id) == best.used.end()) {
      best.rejected.push_back(c.robot_id);
      if (track && atMirrorImageOf(c, *track, options_.gate_chi2)) {
        best.mirrored.push_back(c.robot_id);
      }
    }
  }
  for (const int id : superseded) {
    best.rejected.push_back(id);
    best.superseded.push_back(id);
  }
  std::sort(best.rejected.begin(), best.rejected.end());
  if (mirrored) {
    best.valid = false;
    best.used.clear();
  }
}

perception::TeamState TeamPicture::picture(Utime now, TeamBallResult* team_ball) {
  perception::TeamState s;
  s.utime = now;
  std::vector<BallCandidate> candidates;
  for (int i = 0; i < perception::kTeamSize; ++i) {
    const auto& report = reports_[static_cast<std::size_t>(i)];
    if (!report) continue;
    auto candidate = updateTeammate(*report, now, s.robots[static_cast<std::size_t>(i)]);
    if (!candidate) continue;
    candidate->robot_id = i + 1;
    candidates.push_back(*candidate);
  }
  const std::vector<int> superseded = leaveOutSuperseded(candidates);
  const std::optional<BallCandidate> track = trackAt(now);
  Choice choice = largestConsistentGroup(candidates, track);
  rejectTheOthers(choice, candidates, track, superseded);
  TeamBallResult& best = choice.ball;
  if (best.valid) {
    std::vector<int> sources = carryTrack(now, best);
    track_ = Track{now, best.position, best.velocity, best.covariance, std::move(sources)};
    s.team_ball_valid = true;
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
