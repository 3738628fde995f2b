// Where a run's team ball error comes from: every scored team picture put into one class by the
// ball's true motion and the reporters the team ball used (how many, how far, whether they
// report a resting ball as rolling), with each class's share of the pictures, its mean error,
// its part of the run's mean, the part of that from pictures off by more than large_error_m, and
// its best used reporter's error at that reporter's own stamp (how near the team ball is to what
// it was given). fieldline-team-ball-replay --budget prints it (docs/teamcomm.md "Team ball").
#pragma once

#include <array>
#include <string>
#include <vector>

#include "tools/eval/evaluation.hpp"
#include "tools/eval/team_ball.hpp"

namespace fieldline::eval {

struct BudgetOptions {
  // A ball slower than this rests (teamcomm's ball_rest_speed_mps), m/s.
  double rest_speed_mps = 0.15;
  // A lone reporter at least this far from the ball is far, m.
  double far_m = 3.5;
  // Pictures off by more than this are counted apart within their class, m.
  double large_error_m = 0.1;
  // Pictures stamped less than this after a put-back are not scored, µs.
  Utime put_back_blind_us = TeamBallOptions{}.put_back_blind_us;
};

// One reporter the team ball used.
struct BudgetReporter {
  // From its pose to its ball, m; its ball's reported speed, m/s; its ball's error against the
  // truth at its own stamp, m (NaN: unknown).
  double range_m = 0;
  double reported_speed_mps = 0;
  double error_at_stamp_m = 0;
};

// One valid team picture against the truth.
struct BudgetPicture {
  Utime utime = 0;
  double team_error_m = 0;
  double true_speed_mps = 0;
  std::vector<BudgetReporter> used;
};

enum class BudgetClass {
  kRestShared,           // resting ball, two or more reporters
  kRestLoneNear,         // resting, one reporter nearer than far_m
  kRestLoneFar,          // resting, one reporter at far_m or more
  kRestReportedRolling,  // resting, but every reporter's filter says it rolls (an acquisition)
  kRollingShared,
  kRollingLoneNear,
  kRollingLoneFar,
  kCount
};

const char* budgetClassName(BudgetClass c);
BudgetClass classifyPicture(const BudgetPicture& p, const BudgetOptions& options = {});

struct BudgetRow {
  std::size_t pictures = 0;
  double error_sum_m = 0;
  double large_error_sum_m = 0;
  // Over the pictures with a known error at a reporter's stamp.
  double best_reporter_sum_m = 0;
  std::size_t best_reporter_pictures = 0;
};

struct TeamBallBudget {
  std::size_t pictures = 0;  // scored
  std::size_t left_out = 0;  // in a put-back's blind time, or without a reporter
  std::array<BudgetRow, static_cast<std::size_t>(BudgetClass::kCount)> rows{};
  const BudgetRow& row(BudgetClass c) const { return rows[static_cast<std::size_t>(c)]; }
  // The class's part of the run's mean error, m.
  double contribution(BudgetClass c) const;
  double mean() const;
};

// The put-backs' times come from the truth (isPutBack).
TeamBallBudget teamBallBudget(const std::vector<BudgetPicture>& pictures,
                              const std::vector<TruthSample>& truth,
                              const BudgetOptions& options = {});

// One line per class: "class pictures share mean_m part_of_mean_m of_it_over_large_m
// best_reporter_at_stamp_m".
std::string budgetTable(const TeamBallBudget& b, const BudgetOptions& options = {});

}  // namespace fieldline::eval
