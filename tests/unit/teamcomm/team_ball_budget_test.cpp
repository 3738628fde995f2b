// The team ball's error budget by class (tools/eval/team_ball_budget.hpp) on synthetic pictures.
#include "tools/eval/team_ball_budget.hpp"

#include <gtest/gtest.h>

#include <limits>

namespace fieldline::eval {
namespace team_ball_budget_test {

constexpr Utime kT0 = 1'800'000'000'000'000;

BudgetPicture picture(Utime t, double error, double true_speed, std::vector<BudgetReporter> used) {
  return {kT0 + t, error, true_speed, std::move(used)};
}

TEST(teamcomm_team_ball_budget, EachPictureFallsIntoTheClassOfItsBallAndReporters) {
  const BudgetReporter near_resting{2.0, 0.0, 0.01};
  const BudgetReporter far_resting{4.5, 0.05, 0.04};
  const BudgetReporter far_rolling{4.5, 1.2, 0.20};
  EXPECT_EQ(classifyPicture(picture(0, 0.01, 0.0, {near_resting, far_resting})),
            BudgetClass::kRestShared);
  EXPECT_EQ(classifyPicture(picture(0, 0.01, 0.0, {near_resting})), BudgetClass::kRestLoneNear);
  EXPECT_EQ(classifyPicture(picture(0, 0.04, 0.0, {far_resting})), BudgetClass::kRestLoneFar);
  // A resting ball every reporter's filter says rolls: a far robot's acquisition.
  EXPECT_EQ(classifyPicture(picture(0, 0.2, 0.0, {far_rolling})),
            BudgetClass::kRestReportedRolling);
  // One reporter that says it rests is enough for the resting classes.
  EXPECT_EQ(classifyPicture(picture(0, 0.02, 0.0, {far_rolling, near_resting})),
            BudgetClass::kRestShared);
  EXPECT_EQ(classifyPicture(picture(0, 0.05, 2.0, {far_rolling})), BudgetClass::kRollingLoneFar);
  EXPECT_EQ(classifyPicture(picture(0, 0.05, 2.0, {near_resting})), BudgetClass::kRollingLoneNear);
  EXPECT_EQ(classifyPicture(picture(0, 0.05, 2.0, {near_resting, far_rolling})),
            BudgetClass::kRollingShared);
}

TEST(teamcomm_team_ball_budget, TheClassesPartsAddUpToTheRunsMeanWithoutThePutBacks) {
  // The ball rests at (1, 0) and is put to (4, 0) at 2 s.
  std::vector<TruthSample> truth;
  for (Utime t = 0; t <= 4'000'000; t += 10'000) {
    TruthSample s;
    s.utime = kT0 + t;
    s.robots[1] = {0, 0, 0, 0};
    s.ball_x = t < 2'000'000 ? 1.0 : 4.0;
    truth.push_back(s);
  }
  std::vector<BudgetPicture> pictures;
  const BudgetReporter near{1.0, 0.0, 0.01}, far{5.0, 0.0, 0.05}, acquiring{5.0, 1.5, 0.3};
  // Its error at its stamp unknown (no truth there): scored, not in the reporters' mean.
  const BudgetReporter unknown{5.0, 0.0, std::numeric_limits<double>::quiet_NaN()};
  pictures.push_back(picture(100'000, 0.01, 0.0, {near}));
  pictures.push_back(picture(200'000, 0.04, 0.0, {far}));
  pictures.push_back(picture(300'000, 0.30, 0.0, {acquiring}));
  pictures.push_back(picture(400'000, 0.05, 0.0, {far}));
  pictures.push_back(picture(500'000, 0.06, 0.0, {unknown}));
  pictures.push_back(picture(2'050'000, 3.0, 0.0, {near}));  // the put-back's blind time
  pictures.push_back(picture(2'500'000, 0.5, 0.0, {}));      // no reporter: not a team ball
  const TeamBallBudget b = teamBallBudget(pictures, truth);
  EXPECT_EQ(b.pictures, 5u);
  EXPECT_EQ(b.left_out, 2u);
  EXPECT_NEAR(b.mean(), (0.01 + 0.04 + 0.30 + 0.05 + 0.06) / 5, 1e-12);
  EXPECT_EQ(b.row(BudgetClass::kRestLoneFar).pictures, 3u);
  EXPECT_EQ(b.row(BudgetClass::kRestLoneFar).best_reporter_pictures, 2u);
  EXPECT_NEAR(b.contribution(BudgetClass::kRestLoneFar), 0.15 / 5, 1e-12);
  EXPECT_NEAR(b.contribution(BudgetClass::kRestReportedRolling), 0.30 / 5, 1e-12);
  EXPECT_NEAR(b.row(BudgetClass::kRestReportedRolling).large_error_sum_m, 0.30, 1e-12);
  EXPECT_NEAR(b.row(BudgetClass::kRestLoneFar).large_error_sum_m, 0.0, 1e-12);
  EXPECT_NEAR(b.row(BudgetClass::kRestLoneFar).best_reporter_sum_m, 0.10, 1e-12);
  const std::string table = budgetTable(b);
  EXPECT_NE(table.find("5 scored pictures (2 left out), mean 0.0920 m"), std::string::npos)
      << table;
  EXPECT_NE(table.find("resting, reported rolling"), std::string::npos) << table;
  EXPECT_EQ(table.find("rolling, lone far reporter"), std::string::npos) << table;
}

}  // namespace team_ball_budget_test
}  // namespace fieldline::eval
