// The localization evaluation: every ROBOT_STATE and BALL_STATE matched with the simulator's
// truth at the same utime, summarised into the figures (position and heading error,
// kidnap recovery, wrong-half commits, NEES consistency, ball error) and plotted.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/time/clock.hpp"

namespace fieldline::eval {

struct TruthRobot {
  double x = 0, y = 0, phi = 0;
  int kidnaps = 0;
};

struct TruthSample {
  Utime utime = 0;
  std::map<int, TruthRobot> robots;
  double ball_x = 0, ball_y = 0;
};

struct StateSample {
  int robot = 0;
  Utime utime = 0;
  Utime published = 0;
  double x = 0, y = 0, phi = 0;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  int status = 0;
  // ROBOT_STATE's twin_ambiguous: the pose may be its symmetric twin, and says so.
  bool twin_ambiguous = false;
};

struct BallSample {
  int robot = 0;
  Utime utime = 0;
  bool valid = false;
  double x = 0, y = 0;
  // Position covariance the robot reported, m^2 (zero: none).
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
};

struct EvalOptions {
  // A robot's samples in the first seconds after its first state, and before its first
  // TRACKING, are not scored (start-up is reported as tracking_after_s).
  double settle_s = 2.0;
  // A kidnapped robot has recovered when it tracks within this of the truth, m.
  double recovered_m = 0.2;
  // The ball error counts when the robot is within this of the ball, m.
  double ball_range_m = 4.0;
};

// One matched robot state.
struct Matched {
  int robot = 0;
  double t = 0;  // s since the first state
  double x = 0, y = 0, phi = 0, true_x = 0, true_y = 0, true_phi = 0;
  double pos_error = 0, heading_error = 0, nees = 0;
  int status = 0;
  bool twin_ambiguous = false;
  bool recovering = false;  // between a kidnap and its recovery: not in the error figures
  double latency_ms = 0;
};

// One scored BALL_STATE (valid, after the settle time, the robot within ball_range_m).
struct BallMatched {
  int robot = 0;
  double t = 0;  // s since the first state
  double x = 0, y = 0, true_x = 0, true_y = 0;
  double error = 0;
  // Distance from the robot to the ball, m.
  double range = 0;
};

struct Summary {
  std::size_t states = 0, scored = 0, balls_scored = 0;
  double pos_mean_m = 0, pos_p99_m = 0, pos_max_m = 0, heading_mean_deg = 0;
  double recovery_median_s = 0, recovery_max_s = 0;
  int kidnaps = 0, unrecovered = 0;
  int wrong_half = 0;
  double nees_in_band = 0;
  double ball_mean_m = 0;
  double latency_p50_ms = 0, latency_p95_ms = 0;
  std::map<int, double> pos_mean_by_robot;
  // Per robot: seconds from its first ROBOT_STATE to its first TRACKING (-1: never), and the
  // ROBOT_STATE and BALL_STATE rates over its run, Hz.
  std::map<int, double> tracking_after_s;
  // Seconds from the robot's first VISION_LINES frame to its first TRACKING (-1: never).
  std::map<int, double> tracking_after_vision_s;
  std::map<int, double> robot_state_hz;
  std::map<int, double> ball_state_hz;
  // Per robot: the median interval between its BALL_STATE stamps, ms. Fusion publishes on a
  // timer that skips the ticks it missed, so a loaded machine lowers the rate; the median
  // stays the timer's period until half the ticks are lost.
  std::map<int, double> ball_state_interval_p50_ms;
  // Per robot: the longest of those intervals, ms (a fusion that stopped publishing for a while).
  std::map<int, double> ball_state_interval_max_ms;
  std::vector<double> recoveries_s;
  std::vector<Matched> matched;
  std::vector<BallMatched> balls;
};

// The q-quantile (0..1) of `v`, linearly interpolated between its order statistics; 0 when empty.
double percentile(std::vector<double> v, double q);

// Truth at `t` interpolated between the bracketing samples (sorted by utime); false outside.
bool truthAt(const std::vector<TruthSample>& truth, Utime t, int robot, TruthRobot& out,
             double* ball_x = nullptr, double* ball_y = nullptr);

// Whether the ball jumped from `a` to `b` (consecutive truth samples) faster than any kick: a
// put-back (the scenario placed it elsewhere).
bool isPutBack(const TruthSample& a, const TruthSample& b);
// When the truth shows each put-back (the first sample with the ball at its new place), and
// whether `t` lies in the blind time `blind_us` after one (TeamBallOptions::put_back_blind_us).
std::vector<Utime> putBackTimes(const std::vector<TruthSample>& truth);
bool justAfterPutBack(const std::vector<Utime>& put_backs, Utime t, Utime blind_us);

// `first_lines` (optional): per robot, the utime of its first VISION_LINES frame, from which
// tracking_after_vision_s is measured.
Summary evaluate(const std::vector<TruthSample>& truth, std::vector<StateSample> states,
                 std::vector<BallSample> balls, const EvalOptions& options = {},
                 const std::map<int, Utime>& first_lines = {});

// The one line the issue asks for.
std::string summaryLine(const Summary& s);
std::string summaryJson(const Summary& s, const std::string& source);
// The gnuplot script that draws errors.png (position and heading error over time), latency.png
// (ROBOT_STATE latency over time) and trajectories.png (estimates and truth on the field) into
// `dir`, with the samples in it: time axes, units and a legend per robot.
std::string plotScript(const Summary& s, const std::string& dir, double half_length,
                       double half_width);
// Writes `dir`/plots.gp and runs gnuplot on it (Debian's gnuplot-nox, scripts/setup); false when
// gnuplot failed or is missing (its messages in `dir`/plots.log). `half_length`/`half_width`: the
// field's.
bool writePlots(const Summary& s, const std::string& dir, double half_length, double half_width);

}  // namespace fieldline::eval
