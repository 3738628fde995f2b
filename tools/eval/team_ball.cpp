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

// Every robot's TEAM_STATEs (sorted, valid team ball, after `start`) paired with its newest own
// BALL_STATE at most pair_window_us before: both errors on the same instants (TeamBallSummary
// `paired`), and the verdict against every robot with enough pairs.
void pairOwnWithTeam(const std::vector<TruthSample>& truth, const std::vector<BallSample>& balls,
                     const std::vector<TeamSample>& teams, Utime start,
                     const std::vector<Utime>& put_backs, const TeamBallOptions& options,
                     TeamBallSummary& s) {
  std::map<int, std::vector<const BallSample*>> own;
  for (const BallSample& b : balls)
    own[b.robot].push_back(&b);
  for (auto& [robot, v] : own) {
    std::stable_sort(v.begin(), v.end(),
                     [](const BallSample* a, const BallSample* b) { return a->utime < b->utime; });
  }
  std::map<int, std::pair<double, double>> sums;  // (own, team)
  for (const TeamSample& t : teams) {
    if (t.utime < start || !t.team_ball_valid) continue;
    if (justAfterPutBack(put_backs, t.utime, options.put_back_blind_us)) continue;
    const auto found = own.find(t.robot);
    if (found == own.end()) continue;
    const auto& v = found->second;
    const auto it = std::upper_bound(v.begin(), v.end(), t.utime,
                                     [](Utime u, const BallSample* b) { return u < b->utime; });
    if (it == v.begin()) continue;
    const BallSample& b = **std::prev(it);
    if (!b.valid || t.utime - b.utime > options.pair_window_us) continue;
    if (justAfterPutBack(put_backs, b.utime, options.put_back_blind_us)) continue;
    double tx = 0, ty = 0, bx = 0, by = 0;
    if (!ballAt(truth, t.utime, tx, ty) || !ballAt(truth, b.utime, bx, by)) continue;
    const double own_error = std::hypot(b.x - bx, b.y - by);
    const double team_error = std::hypot(t.team_ball_x - tx, t.team_ball_y - ty);
    sums[t.robot].first += own_error;
    sums[t.robot].second += team_error;
    s.pairs.push_back({t.robot, t.utime, own_error, team_error});
    ++s.paired[t.robot].pairs;
  }
  for (auto& [robot, p] : s.paired) {
    const double n = static_cast<double>(p.pairs);
    p.own_mean_m = sums[robot].first / n;
    p.team_mean_m = sums[robot].second / n;
    if (p.pairs >= options.min_own_samples && p.team_mean_m > p.own_mean_m)
      s.team_ball_worse_robots.push_back(robot);
  }
  if (const auto best = s.paired.find(s.best_own_robot); best != s.paired.end()) {
    s.team_ball_on_best_own_m = best->second.team_mean_m;
    s.best_own_paired_m = best->second.own_mean_m;
  }
}

}  // namespace

namespace {

// Every robot's TEAM_STATE team ball (valid, from `start`): mean error and NEES shares.
void scoreTeamBalls(const std::vector<TruthSample>& truth, const std::vector<TeamSample>& teams,
                    Utime start, const std::vector<Utime>& put_backs,
                    const TeamBallOptions& options, TeamBallSummary& s) {
  double sum = 0, sum_after_put_backs = 0;
  std::size_t nees_n = 0, nees_in = 0, nees_below = 0;
  double nees_sum = 0;
  for (const TeamSample& t : teams) {
    if (t.utime < start || !t.team_ball_valid) continue;
    double bx = 0, by = 0;
    if (!ballAt(truth, t.utime, bx, by)) continue;
    const Eigen::Vector2d error(t.team_ball_x - bx, t.team_ball_y - by);
    if (justAfterPutBack(put_backs, t.utime, options.put_back_blind_us)) {
      sum_after_put_backs += error.norm();
      ++s.team_samples_after_put_backs;
      continue;
    }
    sum += error.norm();
    ++s.team_samples;
    if (const auto n = nees2(error, t.team_ball_covariance)) {
      ++nees_n;
      nees_sum += *n;
      if (inBand(*n)) ++nees_in;
      if (*n < kNees2Low) ++nees_below;
    }
  }
  if (s.team_samples > 0) s.team_ball_mean_m = sum / static_cast<double>(s.team_samples);
  const std::size_t all = s.team_samples + s.team_samples_after_put_backs;
  if (all > 0) {
    s.team_ball_mean_with_put_backs_m = (sum + sum_after_put_backs) / static_cast<double>(all);
  }
  if (nees_n > 0) {
    s.team_ball_nees_in_band = static_cast<double>(nees_in) / static_cast<double>(nees_n);
    s.team_ball_nees_mean = nees_sum / static_cast<double>(nees_n);
    s.team_ball_nees_below = static_cast<double>(nees_below) / static_cast<double>(nees_n);
    s.team_ball_nees_above = 1.0 - s.team_ball_nees_in_band - s.team_ball_nees_below;
  }
}

// Every robot's own ball (valid, from `start` to `end`): mean error, NEES share, the best robot.
void scoreOwnBalls(const std::vector<TruthSample>& truth, const std::vector<BallSample>& balls,
                   Utime start, Utime end, const std::vector<Utime>& put_backs,
                   const TeamBallOptions& options, TeamBallSummary& s) {
  std::map<int, double> own_sum;
  std::map<int, std::pair<std::size_t, std::size_t>> own_nees;  // (in band, with a covariance)
  for (const BallSample& b : balls) {
    if (!b.valid || b.utime < start || b.utime > end) continue;
    double bx = 0, by = 0;
    if (!ballAt(truth, b.utime, bx, by)) continue;
    if (justAfterPutBack(put_backs, b.utime, options.put_back_blind_us)) {
      ++s.own_samples_after_put_backs;
      continue;
    }
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
}

// Over time, every step_us from `start` to `end`: the newest TEAM_STATE of every robot, whether
// some robot sees the ball and every robot has a valid team ball.
void scoreValidity(const std::vector<TeamSample>& teams, Utime start, Utime end,
                   const TeamBallOptions& options, TeamBallSummary& s) {
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
}

}  // namespace

TeamBallSummary evaluateTeamBall(const std::vector<TruthSample>& truth,
                                 const std::vector<BallSample>& balls,
                                 std::vector<TeamSample> teams, const TeamBallOptions& options) {
  TeamBallSummary s;
  if (teams.empty() || truth.empty()) return s;
  std::sort(teams.begin(), teams.end(),
            [](const TeamSample& a, const TeamSample& b) { return a.utime < b.utime; });
  const Utime start = teams.front().utime + static_cast<Utime>(options.settle_s * 1e6);
  const Utime end = std::min(teams.back().utime, truth.back().utime);
  std::vector<Utime> put_backs = putBackTimes(truth);
  std::erase_if(put_backs,
                [&](Utime p) { return p + options.put_back_blind_us <= start || p > end; });
  s.put_backs = put_backs.size();
  s.put_back_blind_us = options.put_back_blind_us;
  scoreTeamBalls(truth, teams, start, put_backs, options, s);
  scoreOwnBalls(truth, balls, start, end, put_backs, options, s);
  pairOwnWithTeam(truth, balls, teams, start, put_backs, options, s);
  scoreValidity(teams, start, end, options, s);
  return s;
}

std::string teamBallLine(const TeamBallSummary& s) {
  std::string own;
  for (const auto& [robot, mean] : s.own_ball_mean_m)
    own += fmt::format(" {}={:.4f}", robot, mean);
  std::string worse;
  for (const int robot : s.team_ball_worse_robots)
    worse += fmt::format("{}{}", worse.empty() ? "" : ",", robot);
  std::size_t best_pairs = 0;
  if (const auto it = s.paired.find(s.best_own_robot); it != s.paired.end())
    best_pairs = it->second.pairs;
  return fmt::format(
      "team_ball_mean_m={:.4f} best_own_ball_mean_m={:.4f} (robot {}) "
      "team_ball_on_best_own_m={:.4f} (own {:.4f} on the same {} instants) "
      "team_ball_worse_than_own={} "
      "team_ball_nees_in_band={:.3f} (below {:.3f}, above {:.3f}) team_ball_valid_share={:.3f} "
      "({} steps with the ball seen) put_backs={} (left out {:.2f} s after each: {} team, {} "
      "own samples; team_ball_mean_m with them {:.4f}) own_ball_mean_m:{}",
      s.team_ball_mean_m, s.best_own_ball_mean_m, s.best_own_robot, s.team_ball_on_best_own_m,
      s.best_own_paired_m, best_pairs, worse.empty() ? "none" : worse, s.team_ball_nees_in_band,
      s.team_ball_nees_below, s.team_ball_nees_above, s.team_ball_valid_share, s.steps_any_sees,
      s.put_backs, static_cast<double>(s.put_back_blind_us) * 1e-6, s.team_samples_after_put_backs,
      s.own_samples_after_put_backs, s.team_ball_mean_with_put_backs_m,
      own.empty() ? " none" : own);
}

std::string teamBallJson(const TeamBallSummary& s) {
  std::ostringstream o;
  o << fmt::format(
      "{{\"team_samples\": {}, \"team_ball_mean_m\": {:.5f}, \"team_ball_nees_in_band\": "
      "{:.4f}, \"team_ball_nees_mean\": {:.3f}, \"best_own_robot\": {}, "
      "\"best_own_ball_mean_m\": {:.5f}, \"steps_any_sees\": {}, \"team_ball_valid_share\": "
      "{:.4f}, \"team_ball_nees_below\": {:.4f}, \"team_ball_nees_above\": {:.4f}, "
      "\"team_ball_on_best_own_m\": {:.5f}, \"best_own_paired_m\": {:.5f}, \"put_backs\": {}, "
      "\"team_samples_after_put_backs\": {}, \"own_samples_after_put_backs\": {}, "
      "\"team_ball_mean_with_put_backs_m\": {:.5f},\n",
      s.team_samples, s.team_ball_mean_m, s.team_ball_nees_in_band, s.team_ball_nees_mean,
      s.best_own_robot, s.best_own_ball_mean_m, s.steps_any_sees, s.team_ball_valid_share,
      s.team_ball_nees_below, s.team_ball_nees_above, s.team_ball_on_best_own_m,
      s.best_own_paired_m, s.put_backs, s.team_samples_after_put_backs,
      s.own_samples_after_put_backs, s.team_ball_mean_with_put_backs_m);
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
  map("sees_share", s.sees_share, false);
  o << "  \"team_ball_worse_robots\": [";
  for (std::size_t i = 0; i < s.team_ball_worse_robots.size(); ++i)
    o << (i ? ", " : "") << s.team_ball_worse_robots[i];
  o << "],\n  \"paired\": {";
  bool first = true;
  for (const auto& [robot, p] : s.paired) {
    o << (first ? "" : ", ")
      << fmt::format("\"{}\": {{\"pairs\": {}, \"own_mean_m\": {:.5f}, \"team_mean_m\": {:.5f}}}",
                     robot, p.pairs, p.own_mean_m, p.team_mean_m);
    first = false;
  }
  o << "}\n";
  o << "}\n";
  return o.str();
}

}  // namespace fieldline::eval
