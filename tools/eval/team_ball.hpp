// The team ball evaluation: every robot's TEAM_STATE team ball against the simulator's ball, the
// same for every robot's own BALL_STATE, and how often every robot has a valid team ball while
// any robot sees the ball (config/scenarios/hidden_ball.yaml hides it from some robots behind
// opponents). All times on the true clock (the caller converts the robots' stamps).
#pragma once

#include <array>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "tools/eval/evaluation.hpp"

namespace fieldline::eval {

// One TEAM_STATE of one robot.
struct TeamSample {
  int robot = 0;
  // True time of the message's utime, µs.
  Utime utime = 0;
  bool team_ball_valid = false;
  double team_ball_x = 0, team_ball_y = 0;
  // The team ball's position covariance, m^2 (zero: none).
  Eigen::Matrix2d team_ball_covariance = Eigen::Matrix2d::Zero();
  // Robot r (index r-1) sees the ball: its entry has a valid ball last seen within the window.
  std::array<bool, 6> sees{};
};

struct TeamBallOptions {
  // Samples in the first seconds after the first TEAM_STATE are not scored, s.
  double settle_s = 5.0;
  // A robot "sees" the ball when its own ball was last seen at most this long ago, µs.
  Utime seen_window_us = 300'000;
  // Step of the validity check over time, µs; a robot's TEAM_STATE older than this and a
  // TEAM_STATE period counts as missing.
  Utime step_us = 100'000;
  // A robot's own ball counts for "best" only with at least this many scored samples.
  std::size_t min_own_samples = 30;
  // Pairing a robot's TEAM_STATE with its own ball: its newest BALL_STATE at most this much
  // older than the TEAM_STATE, and valid, µs.
  Utime pair_window_us = 100'000;
  // Ball samples (team and own alike) stamped less than this after a put-back (the scenario
  // placing the ball elsewhere at once) are not scored, as the pose figures leave out the
  // recovery after a kidnap: no estimate can hold the new place before a camera frame of it has
  // been through the camera (61 ms in omni_sim), waited for (up to a frame, 33 ms), placed
  // (image-to-pose p50 14 ms) and sent to the team (a new ball goes out within 28 ms), about
  // 140 ms. Live matches until 2026-12-06: 12 of 1,522 team samples, 4.9-9.3 m off in the
  // 80 ms after two put-backs, were 0.056 m of a 0.088 m team_ball_mean_m. 0: all scored, µs.
  Utime put_back_blind_us = 150'000;
};

// One robot's own ball against its own team ball at the same instants: each of its TEAM_STATEs
// with a valid team ball and a valid own BALL_STATE at most pair_window_us before it.
struct PairedBall {
  std::size_t pairs = 0;
  // Mean error of the own ball and of the team ball over those instants, m.
  double own_mean_m = -1;
  double team_mean_m = -1;
};

struct TeamBallSummary {
  std::size_t team_samples = 0;
  // Put-backs in the scored span, and the team and own ball samples left out after them
  // (TeamBallOptions::put_back_blind_us); the team ball's mean with them scored, m.
  std::size_t put_backs = 0;
  Utime put_back_blind_us = 0;
  std::size_t team_samples_after_put_backs = 0;
  std::size_t own_samples_after_put_backs = 0;
  double team_ball_mean_with_put_backs_m = -1;
  // Mean distance of the team ball (all robots' TEAM_STATE, valid) from the true ball, m.
  double team_ball_mean_m = -1;
  // Share of those team balls whose NEES (error against the reported covariance, 2 dof) lies in
  // the central 95 % band of chi-square (0.051-7.38), and their mean NEES (2 when consistent).
  double team_ball_nees_in_band = -1;
  double team_ball_nees_mean = -1;
  // Shares of those below the band (covariance too large for the error) and above it (too
  // small): which way the covariance is wrong.
  double team_ball_nees_below = -1;
  double team_ball_nees_above = -1;
  // Per robot: mean error of its own valid BALL_STATE, m, and the number of samples.
  std::map<int, double> own_ball_mean_m;
  std::map<int, std::size_t> own_ball_samples;
  // Per robot: the same NEES band share of its own ball.
  std::map<int, double> own_ball_nees_in_band;
  // The robot with the smallest own mean (-1: none had enough samples) and that mean.
  int best_own_robot = -1;
  double best_own_ball_mean_m = -1;
  // The fair comparison: team_ball_mean_m covers the whole run (moments no robot sees the ball
  // well, the put-backs), a robot's own mean only the moments its own ball is valid (mostly
  // near). Per robot, both on the same instants (PairedBall), and the team ball's mean on the
  // best robot's instants (-1: no pairs). The team ball is at least as good as every own ball
  // where `team_ball_worse_robots` is empty: robots with at least min_own_samples pairs whose own
  // mean beats the team ball's on their instants.
  std::map<int, PairedBall> paired;
  // Every pair: robot, its TEAM_STATE's true time (µs), own and team ball errors (m).
  struct Pair {
    int robot = 0;
    Utime utime = 0;
    double own_error_m = 0, team_error_m = 0;
  };
  std::vector<Pair> pairs;
  double team_ball_on_best_own_m = -1;
  double best_own_paired_m = -1;
  std::vector<int> team_ball_worse_robots;
  // Time steps in which some robot sees the ball, and the share of them in which every robot
  // (that published TEAM_STATE) has a valid team ball.
  std::size_t steps_any_sees = 0;
  double team_ball_valid_share = -1;
  // Per robot: the share of the run's steps in which it saw the ball itself.
  std::map<int, double> sees_share;
};

TeamBallSummary evaluateTeamBall(const std::vector<TruthSample>& truth,
                                 const std::vector<BallSample>& balls,
                                 std::vector<TeamSample> teams,
                                 const TeamBallOptions& options = {});

// "team_ball_mean_m=0.0086 best_own_ball_mean_m=0.0141 (robot 2) team_ball_nees_in_band=0.912
// team_ball_valid_share=1.000 (312 steps with the ball seen) own_ball_mean_m: 1=0.0141 ..."
std::string teamBallLine(const TeamBallSummary& s);
// A JSON object with every figure.
std::string teamBallJson(const TeamBallSummary& s);

}  // namespace fieldline::eval
