// Teammates' balls against the field's symmetry. A pose and its point-symmetric twin fit the
// lines equally well, and when continuity cannot tell them apart (a push while blind, a start
// away from the own half) the commit is ambiguous. The ball breaks the symmetry: seen from the
// twin, our ball lands at minus where the teammates see it. TeamBallVoter turns one of our ball
// sightings (in the field frame, with our pose at its time) into a vote: the same half, the twin,
// or no say. Teammates rarely all see the ball at once (they block each other's view), so each
// teammate's latest agreement is remembered for a while, and a vote counts the distinct teammates
// that agreed within that window. The Localizer acts on a run of votes (Localizer::addTwinVote).
// Plain library: no LCM, time as arguments.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/perception/team.hpp"
#include "common/time/clock.hpp"

namespace fieldline::fusion {

enum class TwinVote { kNone, kSame, kTwin };

struct TeamBallVoteParams {
  // A teammate's ball within this of ours (or of its mirror image) agrees with it, m.
  double agree_m = 0.5;
  // Our ball must be at least this far from the centre spot: its mirror image is then twice this
  // away, so no teammate's ball agrees with both, m.
  double min_centre_distance_m = 1.0;
  // Distinct teammates whose balls must have agreed (within `evidence_window_us`) before a
  // sighting votes: one mislocalized teammate alone cannot decide.
  int min_teammates = 2;
  // A sighting of ours with a larger standard deviation (the larger of radial and tangential)
  // has no say: its place could agree by chance, m.
  double max_sighting_sigma_m = 0.25;
  // How long a teammate's latest agreement with our ball (or its mirror image) counts, µs.
  Utime evidence_window_us = 2'000'000;
  // A teammate's ball last seen longer ago than this (at the picture's time) is not used, µs.
  Utime max_ball_age_us = 500'000;
  // A team picture further than this from our sighting's time is not used, µs.
  Utime max_picture_gap_us = 250'000;
};

class TeamBallVoter {
 public:
  // `own_robot_id` in 1..perception::kTeamSize (our own entry of a picture is not a teammate);
  // throws std::invalid_argument otherwise or for inconsistent params.
  explicit TeamBallVoter(int own_robot_id, TeamBallVoteParams params = {});

  // The newest team picture (TEAM_STATE). Bad input is counted by kind and changes nothing: a
  // picture older than the one held is refused ("team_state_out_of_order"); a teammate entry
  // with a non-finite ball or a negative age is left out ("team_ball_not_finite",
  // "team_ball_age_negative"); a non-finite team ball velocity is not used
  // ("team_velocity_not_finite").
  void setTeam(const perception::TeamState& team);
  // Our ball at `utime` in the field frame, as our pose at that time puts it, with the larger of
  // its sighting's standard deviations, compared with the teammates' balls carried to `utime`
  // with the team ball's velocity. A sighting less sure than max_sighting_sigma_m has no say, nor
  // one that agrees with no teammate's ball (nor its mirror image); one that does votes by the
  // teammates that agreed within the window, by more than two to one. At most one vote per team
  // picture: the teammates' evidence changes with the picture, not with our frame rate.
  // `pose_certain`: our pose is not ambiguous. Then a teammate that reports its own pose as
  // possibly its twin (TEAM_STATE robot_twin_ambiguous) does not count against ours (its ball
  // may be mirrored: only robots sure of their poses may doubt a certain one); its agreement
  // with our ball still counts for it. An ambiguous pose hears every teammate (at start-up all
  // are ambiguous and confirm each other).
  TwinVote vote(const Eigen::Vector2d& ours, double sigma_m, Utime utime, bool pose_certain);
  // Forgets the agreements: the pose they were judged with changed (a commit, a move to the twin).
  void clearEvidence();
  // Teammates' balls usable at `utime` (for tests).
  std::vector<Eigen::Vector2d> teammateBalls(Utime utime) const;

  const std::map<std::string, std::uint64_t>& refusals() const { return refusals_; }
  const TeamBallVoteParams& params() const { return params_; }

 private:
  // How far the teammates' balls move from the picture's time to `utime` (the team ball's
  // velocity); empty when the picture is too far from `utime`.
  std::optional<Eigen::Vector2d> shiftTo(Utime utime) const;

  int own_robot_id_;
  TeamBallVoteParams params_;
  Utime picture_utime_ = 0;
  // The picture of the last vote (at most one per picture).
  Utime voted_picture_utime_ = -1;
  Eigen::Vector2d team_velocity_ = Eigen::Vector2d::Zero();
  struct TeammateBall {
    int robot_id = 0;
    Eigen::Vector2d position = Eigen::Vector2d::Zero();
    bool twin_ambiguous = false;  // the teammate's pose may be its twin
  };
  std::vector<TeammateBall> balls_;
  // Per robot id (index id - 1): the latest agreement of one of our sightings with its ball
  // (kSame) or with its ball's mirror image (kTwin), and that sighting's utime (0: none). Only the
  // latest counts: a teammate that agreed with us before we were carried off and with our mirror
  // image after has one say, the newer.
  struct Agreement {
    TwinVote kind = TwinVote::kNone;
    Utime utime = 0;
    bool twin_ambiguous = false;  // the teammate's pose was possibly its twin then
  };
  std::array<Agreement, perception::kTeamSize> agreements_{};
  std::map<std::string, std::uint64_t> refusals_;
};

}  // namespace fieldline::fusion
