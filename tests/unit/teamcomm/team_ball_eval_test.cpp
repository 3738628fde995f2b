// fieldline-eval's team-ball figures (tools/eval/team_ball.hpp) on synthetic samples.
#include "tools/eval/team_ball.hpp"

#include <gtest/gtest.h>

namespace fieldline::eval {
namespace team_ball_eval_test {

constexpr Utime kT0 = 1'800'000'000'000'000;

struct Samples {
  std::vector<TruthSample> truth;
  std::vector<BallSample> balls;
  std::vector<TeamSample> teams;
};

// 20 s: the ball at (1, 0); every robot's own ball off by its own error, at 30 Hz; TEAM_STATE at
// 10 Hz with the team ball 1 cm off. Robot 1 sees the ball in the first 10 s only; robot 3's team
// ball is invalid from 15 s on.
Samples makeSamples() {
  Samples r;
  for (Utime t = kT0; t <= kT0 + 20'000'000; t += 10'000) {
    TruthSample s;
    s.utime = t;
    for (int id = 1; id <= 3; ++id)
      s.robots[id] = {0, 0, 0, 0};
    s.ball_x = 1.0;
    r.truth.push_back(s);
  }
  const double own_error[] = {0.0, 0.02, 0.05, 0.30};
  for (Utime t = kT0; t <= kT0 + 20'000'000; t += 33'333) {
    for (int id = 1; id <= 3; ++id)
      r.balls.push_back({id, t, true, 1.0 + own_error[id], 0.0});
  }
  for (Utime t = kT0; t <= kT0 + 20'000'000; t += 100'000) {
    for (int id = 1; id <= 3; ++id) {
      TeamSample s;
      s.robot = id;
      s.utime = t + 1000 * id;
      s.team_ball_valid = !(id == 3 && t >= kT0 + 15'000'000);
      s.team_ball_x = 1.01;
      s.sees[0] = t < kT0 + 10'000'000;
      r.teams.push_back(s);
    }
  }
  return r;
}

TEST(teamcomm_team_ball_eval, TeamBallAgainstTheBestOwnBallAndValidity) {
  const Samples r = makeSamples();
  const TeamBallSummary s = evaluateTeamBall(r.truth, r.balls, r.teams);
  EXPECT_NEAR(s.team_ball_mean_m, 0.01, 1e-9);
  EXPECT_EQ(s.best_own_robot, 1);
  EXPECT_NEAR(s.best_own_ball_mean_m, 0.02, 1e-9);
  EXPECT_NEAR(s.own_ball_mean_m.at(3), 0.30, 1e-9);
  // Robot 1 sees the ball from 5 s (the settle time) to 10 s: every robot's team ball is valid
  // then. After 10 s nobody sees it, so robot 3's invalid team ball from 15 s does not count.
  EXPECT_GT(s.steps_any_sees, 45u);
  EXPECT_LT(s.steps_any_sees, 55u);
  EXPECT_DOUBLE_EQ(s.team_ball_valid_share, 1.0);
  EXPECT_NEAR(s.sees_share.at(1), 5.0 / 15.0, 0.02);
  EXPECT_NE(teamBallLine(s).find("team_ball_mean_m=0.0100"), std::string::npos) << teamBallLine(s);
}

TEST(teamcomm_team_ball_eval, AMissingOrInvalidTeamBallWhileTheBallIsSeenCounts) {
  Samples r = makeSamples();
  // Robot 1 sees the ball all the time now: robot 3's invalid team ball from 15 s counts, and so
  // does robot 2's silence from 12 to 13 s.
  for (TeamSample& t : r.teams)
    t.sees[0] = true;
  std::erase_if(r.teams, [](const TeamSample& t) {
    return t.robot == 2 && t.utime > kT0 + 12'000'000 && t.utime < kT0 + 13'000'000;
  });
  const TeamBallSummary s = evaluateTeamBall(r.truth, r.balls, r.teams);
  // 150 steps from 5 s to 20 s; invalid: 15-20 s (50) and 9 steps of the silent second (a
  // TEAM_STATE counts as missing after 200 ms).
  EXPECT_EQ(s.steps_any_sees, 150u);
  EXPECT_NEAR(s.team_ball_valid_share, (150.0 - 50.0 - 9.0) / 150.0, 0.01);
  EXPECT_LT(evaluateTeamBall(r.truth, r.balls, {}).team_ball_mean_m, 0.0);  // nothing to score
}

TEST(teamcomm_team_ball_eval, TheTeamBallsAndOwnBallsConsistency) {
  Samples r = makeSamples();
  // The team ball is 1 cm off: with a 1 cm sigma its NEES is 1 (in the band), robot 3 claims
  // 1 mm (NEES 100, out of it); no covariance (robot 2 before 10 s) is not scored for NEES.
  for (TeamSample& t : r.teams) {
    const double sigma = t.robot == 3 ? 0.001 : 0.01;
    if (!(t.robot == 2 && t.utime < kT0 + 10'000'000))
      t.team_ball_covariance = Eigen::Matrix2d::Identity() * sigma * sigma;
  }
  // Own balls: robot 1 (2 cm off) says 2 cm, robot 2 (5 cm off) says 1 cm (NEES 25).
  for (BallSample& b : r.balls) {
    const double sigma = b.robot == 2 ? 0.01 : 0.02;
    b.covariance = Eigen::Matrix2d::Identity() * sigma * sigma;
  }
  const TeamBallSummary s = evaluateTeamBall(r.truth, r.balls, r.teams);
  // Scored from 5 s: robot 1 15 s in the band, robot 2 10 s (from 10 s), robot 3 10 s out of it
  // (its team ball is invalid from 15 s).
  EXPECT_NEAR(s.team_ball_nees_in_band, 250.0 / 350.0, 0.01);
  EXPECT_NEAR(s.team_ball_nees_mean, (250.0 * 1.0 + 100.0 * 100.0) / 350.0, 0.5);
  EXPECT_DOUBLE_EQ(s.own_ball_nees_in_band.at(1), 1.0);
  EXPECT_DOUBLE_EQ(s.own_ball_nees_in_band.at(2), 0.0);
  const std::string line = teamBallLine(s);
  EXPECT_NE(line.find("team_ball_nees_in_band=0.71"), std::string::npos) << line;
  EXPECT_NE(line.find("own_ball_mean_m: 1=0.0200 2=0.0500 3=0.3000"), std::string::npos) << line;
}

TEST(teamcomm_team_ball_eval, TheTeamBallAgainstEachOwnBallOnTheSameInstants) {
  Samples r = makeSamples();
  // A put-back at 15 s: for a second every team ball is 1 m off while robot 1's own ball is
  // invalid (it saw the ball vanish, 14.95-16.05 s). Over the whole run the team ball looks worse
  // than robot 1's own ball, which is not scored in that second; on robot 1's own instants the
  // team ball is better. Robot 2's own ball (5 cm off) stays valid: on its instants the team
  // ball's second counts, and there the team ball is worse.
  for (BallSample& b : r.balls) {
    if (b.robot == 1 && b.utime >= kT0 + 14'950'000 && b.utime < kT0 + 16'050'000) b.valid = false;
  }
  for (TeamSample& t : r.teams) {
    if (t.utime >= kT0 + 15'000'000 && t.utime < kT0 + 16'000'000) t.team_ball_x = 2.0;
  }
  const TeamBallSummary s = evaluateTeamBall(r.truth, r.balls, r.teams);
  EXPECT_EQ(s.best_own_robot, 1);
  EXPECT_GT(s.team_ball_mean_m, s.best_own_ball_mean_m);  // the whole run: 1 m for 10 of 150
  // Robot 1: 139 of its 150 TEAM_STATEs from 5 s to 20 s have a valid own ball before them.
  ASSERT_TRUE(s.paired.contains(1));
  EXPECT_EQ(s.paired.at(1).pairs, 139u);
  EXPECT_NEAR(s.paired.at(1).own_mean_m, 0.02, 1e-9);
  EXPECT_NEAR(s.paired.at(1).team_mean_m, 0.01, 1e-9);
  EXPECT_NEAR(s.team_ball_on_best_own_m, 0.01, 1e-9);
  EXPECT_NEAR(s.best_own_paired_m, 0.02, 1e-9);
  // Robot 2 (own 5 cm off, valid throughout): team (140 * 0.01 + 10 * 1.0) / 150 = 7.6 cm.
  EXPECT_EQ(s.paired.at(2).pairs, 150u);
  EXPECT_NEAR(s.paired.at(2).team_mean_m, (140 * 0.01 + 10 * 1.0) / 150.0, 1e-9);
  EXPECT_EQ(s.team_ball_worse_robots, std::vector<int>{2});
  const std::string line = teamBallLine(s);
  EXPECT_NE(line.find("team_ball_on_best_own_m=0.0100 (own 0.0200 on the same 139 instants)"),
            std::string::npos)
      << line;
  EXPECT_NE(line.find("team_ball_worse_than_own=2"), std::string::npos) << line;
}

TEST(teamcomm_team_ball_eval, APutBackIsNotInterpolated) {
  // The ball at (1, 0) until a truth sample at T, at (5, 0) in the next one 20 ms later: up to
  // the later sample it is at (1, 0), not on the line between (an estimate stamped 0.25 ms before
  // the later sample was scored 4 m off). A rolling ball is still interpolated.
  std::vector<TruthSample> truth;
  for (int k = 0; k <= 2; ++k) {
    TruthSample s;
    s.utime = kT0 + 20'000 * k;
    s.robots[1] = {0, 0, 0, 0};
    s.ball_x = k < 2 ? 1.0 + 0.02 * k : 5.0;  // rolling at 1 m/s, then put back
    truth.push_back(s);
  }
  TruthRobot robot;
  double bx = 0, by = 0;
  ASSERT_TRUE(truthAt(truth, kT0 + 10'000, 1, robot, &bx, &by));
  EXPECT_NEAR(bx, 1.01, 1e-9);
  ASSERT_TRUE(truthAt(truth, kT0 + 39'750, 1, robot, &bx, &by));
  EXPECT_NEAR(bx, 1.02, 1e-9);
  ASSERT_TRUE(truthAt(truth, kT0 + 40'000, 1, robot, &bx, &by));
  EXPECT_NEAR(bx, 5.0, 1e-9);
}

TEST(teamcomm_team_ball_eval, ThePutBacksBlindTimeIsNotScored) {
  Samples r = makeSamples();
  // The scenario puts the ball from (1, 0) to (4, 0) at 12 s. Every estimate holds the old place
  // until 12.1 s (no camera frame of the new place has come through yet), then has the new one.
  constexpr Utime kPutBack = kT0 + 12'000'000;
  for (TruthSample& t : r.truth) {
    if (t.utime >= kPutBack) t.ball_x = 4.0;
  }
  const auto place = [](Utime t, double error) {
    return (t < kPutBack + 100'000 ? 1.0 : 4.0) + error;
  };
  const double own_error[] = {0.0, 0.02, 0.05, 0.30};
  for (BallSample& b : r.balls)
    b.x = place(b.utime, own_error[b.robot]);
  for (TeamSample& t : r.teams)
    t.team_ball_x = place(t.utime, 0.01);
  const TeamBallSummary s = evaluateTeamBall(r.truth, r.balls, r.teams);
  // Left out: the three TEAM_STATEs at 12.00x s (2.99 m off) and the three at 12.10x s (in place),
  // and the own balls stamped in those 150 ms; the rest as without the put-back.
  EXPECT_EQ(s.put_backs, 1u);
  EXPECT_EQ(s.team_samples_after_put_backs, 6u);
  EXPECT_EQ(s.own_samples_after_put_backs, 12u);
  EXPECT_NEAR(s.team_ball_mean_m, 0.01, 1e-9);
  EXPECT_NEAR(s.own_ball_mean_m.at(1), 0.02, 1e-9);
  const double n = static_cast<double>(s.team_samples);
  EXPECT_NEAR(s.team_ball_mean_with_put_backs_m, (n * 0.01 + 3 * 2.99 + 3 * 0.01) / (n + 6), 1e-9);
  EXPECT_EQ(s.best_own_robot, 1);
  const std::string line = teamBallLine(s);
  EXPECT_NE(line.find("put_backs=1 (left out 0.15 s after each: 6 team, 12 own samples"),
            std::string::npos)
      << line;
  // Scored throughout (0): the put-back's 3 m count.
  TeamBallOptions all;
  all.put_back_blind_us = 0;
  EXPECT_GT(evaluateTeamBall(r.truth, r.balls, r.teams, all).team_ball_mean_m, 0.025);
}

}  // namespace team_ball_eval_test
}  // namespace fieldline::eval
