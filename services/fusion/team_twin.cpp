#include "services/fusion/team_twin.hpp"

#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace fieldline::fusion {

TeamBallVoter::TeamBallVoter(int own_robot_id, TeamBallVoteParams params)
    : own_robot_id_(own_robot_id), params_(params) {
  if (own_robot_id < 1 || own_robot_id > perception::kTeamSize) {
    throw std::invalid_argument("team ball vote: own robot id must be in 1..6");
  }
  // Two teammates agreeing with both our ball and its mirror image would make a vote meaningless.
  if (!(params_.agree_m > 0.0 && params_.min_centre_distance_m > params_.agree_m)) {
    throw std::invalid_argument(
        "team ball vote: agree_m must be > 0 and below min_centre_distance_m");
  }
  if (params_.min_teammates < 1) {
    throw std::invalid_argument("team ball vote: min_teammates must be at least 1");
  }
}

void TeamBallVoter::setTeam(const perception::TeamState& team) {
  if (team.utime < picture_utime_) {
    ++refusals_["team_state_out_of_order"];
    return;
  }
  picture_utime_ = team.utime;
  balls_.clear();
  team_velocity_.setZero();
  if (team.team_ball_valid) {
    if (std::isfinite(team.team_ball_vx) && std::isfinite(team.team_ball_vy)) {
      team_velocity_ = {team.team_ball_vx, team.team_ball_vy};
    } else {
      ++refusals_["team_velocity_not_finite"];
    }
  }
  for (std::size_t i = 0; i < team.robots.size(); ++i) {
    const perception::TeammateState& r = team.robots[i];
    if (static_cast<int>(i) + 1 == own_robot_id_ || !r.present || !r.ball_valid) continue;
    if (!std::isfinite(r.ball_x) || !std::isfinite(r.ball_y)) {
      ++refusals_["team_ball_not_finite"];
      continue;
    }
    if (r.ball_age_us < 0) {
      ++refusals_["team_ball_age_negative"];
      continue;
    }
    if (r.ball_age_us > params_.max_ball_age_us) continue;
    balls_.push_back({static_cast<int>(i) + 1, {r.ball_x, r.ball_y}, r.twin_ambiguous});
  }
}

std::optional<Eigen::Vector2d> TeamBallVoter::shiftTo(Utime utime) const {
  if (std::llabs(utime - picture_utime_) > params_.max_picture_gap_us) return {};
  return team_velocity_ * (static_cast<double>(utime - picture_utime_) * 1e-6);
}

std::vector<Eigen::Vector2d> TeamBallVoter::teammateBalls(Utime utime) const {
  std::vector<Eigen::Vector2d> out;
  if (const auto shift = shiftTo(utime)) {
    for (const TeammateBall& b : balls_)
      out.push_back(b.position + *shift);
  }
  return out;
}

void TeamBallVoter::clearEvidence() {
  agreements_.fill({});
}

TwinVote TeamBallVoter::vote(const Eigen::Vector2d& ours, double sigma_m, Utime utime,
                             bool pose_certain) {
  if (!ours.allFinite() || ours.norm() < params_.min_centre_distance_m) return TwinVote::kNone;
  if (!(sigma_m <= params_.max_sighting_sigma_m)) return TwinVote::kNone;
  const auto shift = shiftTo(utime);
  if (!shift) return TwinVote::kNone;
  bool agreed = false;
  for (const TeammateBall& b : balls_) {
    const Eigen::Vector2d theirs = b.position + *shift;
    const auto k = static_cast<std::size_t>(b.robot_id - 1);
    // min_centre_distance_m > agree_m: at most one of the two holds.
    if ((theirs - ours).norm() <= params_.agree_m) {
      agreements_[k] = {TwinVote::kSame, utime, b.twin_ambiguous};
      agreed = true;
    } else if ((theirs + ours).norm() <= params_.agree_m) {
      agreements_[k] = {TwinVote::kTwin, utime, b.twin_ambiguous};
      agreed = true;
    }
  }
  if (!agreed || voted_picture_utime_ == picture_utime_) return TwinVote::kNone;
  int same = 0;
  int twin = 0;
  for (const Agreement& a : agreements_) {
    if (a.utime == 0 || std::llabs(utime - a.utime) > params_.evidence_window_us) continue;
    if (pose_certain && a.twin_ambiguous && a.kind == TwinVote::kTwin) continue;
    same += a.kind == TwinVote::kSame ? 1 : 0;
    twin += a.kind == TwinVote::kTwin ? 1 : 0;
  }
  // A clear majority only (more than two to one): one teammate on its own twin, which sees the
  // ball mirrored, must not decide the vote; with two against it, it vetoes.
  TwinVote v = TwinVote::kNone;
  if (same >= params_.min_teammates && same > 2 * twin) v = TwinVote::kSame;
  if (twin >= params_.min_teammates && twin > 2 * same) v = TwinVote::kTwin;
  if (v != TwinVote::kNone) voted_picture_utime_ = picture_utime_;
  return v;
}

}  // namespace fieldline::fusion
