#include "tools/eval/team_ball.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include <fmt/format.h>
#include <Eigen/LU>

namespace fieldline::eval {

namespace {

// Chi-square with 2 degrees of freedom: the central 95 % of single-sample NEES values.
constexpr double kNees2Low = 0.0506;
constexpr double kNees2High = 7.3778;

// NEES of a position error against its covariance; nothing without a usable covariance.
std::optional<double> nees2(const Eigen::Vector2d& error, const Eigen::Matrix2d& covariance) {
  if (!(covariance.determinant() > 0.0) || !covariance.allFinite()) return std::nullopt;
  return error.dot(covariance.inverse() * error);
}

bool inBand(double nees) {
  return nees >= kNees2Low && nees <= kNees2High;
}

// The true ball at `t` (any robot's truth sample carries it); false outside the truth.
bool ballAt(const std::vector<TruthSample>& truth, Utime t, double& x, double& y) {
  if (truth.empty() || truth.front().robots.empty()) return false;
  TruthRobot unused;
  return truthAt(truth, t, truth.front().robots.begin()->first, unused, &x, &y);
}

}  // namespace

TeamBallSummary evaluateTeamBall(const std::vector<TruthSample>& truth,
                                 const std::vector<BallSample>& balls,
                                 std::vector<TeamSample> teams, const TeamBallOptions& options) {
  TeamBallSummary s;
  if (teams.empty() || truth.empty()) return s;
  std::sort(teams.begin(), teams.end(),
            [](const TeamSample& a, const TeamSample& b) { return a.utime < b.utime; });
  Utime start = teams.front().utime;
  const Utime end = std::min(teams.back().utime, truth.back().utime);
  start += static_cast<Utime>(options.settle_s * 1e6);

  // The team ball of every robot.
  double sum = 0;
  std::size_t nees_n = 0, nees_in = 0;
  double nees_sum = 0;
  for (const TeamSample& t : teams) {
    if (t.utime < start || !t.team_ball_valid) continue;
    double bx = 0, by = 0;
    if (!ballAt(truth, t.utime, bx, by)) continue;
    const Eigen::Vector2d error(t.team_ball_x - bx, t.team_ball_y - by);
    sum += error.norm();
    ++s.team_samples;
    if (const auto n = nees2(error, t.team_ball_covariance)) {
      ++nees_n;
      nees_sum += *n;
      if (inBand(*n)) ++nees_in;
    }
  }
  if (s.team_samples > 0) s.team_ball_mean_m = sum / static_cast<double>(s.team_samples);
  if (nees_n > 0) {
    s.team_ball_nees_in_band = static_cast<double>(nees_in) / static_cast<double>(nees_n);
    s.team_ball_nees_mean = nees_sum / static_cast<double>(nees_n);
  }

  // Every robot's own ball, over the same span.
  std::map<int, double> own_sum;
  std::map<int, std::pair<std::size_t, std::size_t>> own_nees;  // (in band, with a covariance)
  for (const BallSample& b : balls) {
    if (!b.valid || b.utime < start || b.utime > end) continue;
    double bx = 0, by = 0;
    if (!ballAt(truth, b.utime, bx, by)) continue;
    const Eigen::Vector2d error(b.x - bx, b.y - by);
    own_sum[b.robot] += error.norm();
    ++s.own_ball_samples[b.robot];
    if (const auto n = nees2(error, b.covariance)) {
      ++own_nees[b.robot].second;
      if (inBand(*n)) ++own_nees[b.robot].first;
    }
  }
  for (const auto& [robot, counts] : own_nees) {
    s.own_ball_nees_in_band[robot] =
        static_cast<double>(counts.first) / static_cast<double>(counts.second);
  }
  for (const auto& [robot, total] : own_sum) {
    const std::size_t n = s.own_ball_samples[robot];
    s.own_ball_mean_m[robot] = total / static_cast<double>(n);
    if (n >= options.min_own_samples &&
        (s.best_own_robot < 0 || s.own_ball_mean_m[robot] < s.best_own_ball_mean_m)) {
      s.best_own_robot = robot;
      s.best_own_ball_mean_m = s.own_ball_mean_m[robot];
    }
  }

  // Over time: the newest TEAM_STATE of every robot at each step.
  std::map<int, std::vector<const TeamSample*>> by_robot;
  for (const TeamSample& t : teams)
    by_robot[t.robot].push_back(&t);
  std::size_t steps = 0, all_valid = 0;
  std::map<int, std::size_t> sees_steps;
  for (Utime now = start; now <= end; now += options.step_us) {
    ++steps;
    bool any_sees = false;
    bool every_valid = true;
    for (const auto& [robot, samples] : by_robot) {
      const auto it = std::upper_bound(samples.begin(), samples.end(), now,
                                       [](Utime v, const TeamSample* t) { return v < t->utime; });
      const TeamSample* latest = it == samples.begin() ? nullptr : *std::prev(it);
      // Missing: nothing yet, or nothing for longer than a step and a TEAM_STATE period.
      if (!latest || now - latest->utime > 2 * options.step_us) {
        every_valid = false;
        continue;
      }
      every_valid = every_valid && latest->team_ball_valid;
      if (robot >= 1 && robot <= 6 && latest->sees[static_cast<std::size_t>(robot - 1)]) {
        any_sees = true;
        ++sees_steps[robot];
      }
    }
    if (!any_sees) continue;
    ++s.steps_any_sees;
    if (every_valid) ++all_valid;
  }
  if (s.steps_any_sees > 0) {
    s.team_ball_valid_share =
        static_cast<double>(all_valid) / static_cast<double>(s.steps_any_sees);
  }
  for (const auto& [robot, samples] : by_robot) {
    s.sees_share[robot] =
        steps == 0 ? 0.0 : static_cast<double>(sees_steps[robot]) / static_cast<double>(steps);
  }
  return s;
}

std::string teamBallLine(const TeamBallSummary& s) {
  std::string own;
  for (const auto& [robot, mean] : s.own_ball_mean_m)
    own += fmt::format(" {}={:.4f}", robot, mean);
  return fmt::format(
      "team_ball_mean_m={:.4f} best_own_ball_mean_m={:.4f} (robot {}) "
      "team_ball_nees_in_band={:.3f} team_ball_valid_share={:.3f} ({} steps with the ball seen) "
      "own_ball_mean_m:{}",
      s.team_ball_mean_m, s.best_own_ball_mean_m, s.best_own_robot, s.team_ball_nees_in_band,
      s.team_ball_valid_share, s.steps_any_sees, own.empty() ? " none" : own);
}

std::string teamBallJson(const TeamBallSummary& s) {
  std::ostringstream o;
  o << fmt::format(
      "{{\"team_samples\": {}, \"team_ball_mean_m\": {:.5f}, \"team_ball_nees_in_band\": "
      "{:.4f}, \"team_ball_nees_mean\": {:.3f}, \"best_own_robot\": {}, "
      "\"best_own_ball_mean_m\": {:.5f}, \"steps_any_sees\": {}, \"team_ball_valid_share\": "
      "{:.4f},\n",
      s.team_samples, s.team_ball_mean_m, s.team_ball_nees_in_band, s.team_ball_nees_mean,
      s.best_own_robot, s.best_own_ball_mean_m, s.steps_any_sees, s.team_ball_valid_share);
  const auto map = [&o](const char* name, const auto& m, bool last) {
    o << "  \"" << name << "\": {";
    bool first = true;
    for (const auto& [robot, value] : m) {
      o << (first ? "" : ", ") << '"' << robot << "\": " << fmt::format("{:.5f}", value);
      first = false;
    }
    o << (last ? "}\n" : "},\n");
  };
  map("own_ball_mean_m", s.own_ball_mean_m, false);
  map("own_ball_nees_in_band", s.own_ball_nees_in_band, false);
  map("sees_share", s.sees_share, true);
  o << "}\n";
  return o.str();
}

}  // namespace fieldline::eval
