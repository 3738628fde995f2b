// The team picture: teammates aged and predicted to now, presence, and the team ball's
// covariance-weighted fusion with its consistency gate.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <random>

#include "common/config/config.hpp"
#include "common/msg/team_state.hpp"
#include "services/fusion/ball_filter.hpp"
#include "teamcomm/team_picture.hpp"
#include "teamcomm/teamcomm_config.hpp"

namespace fieldline::teamcomm {
namespace team_picture_test {

constexpr Utime kT0 = 1'700'000'000'000'000;

Report report(double x, double y, Utime t, double pose_sigma = 0.05) {
  Report r;
  r.robot.utime = t;
  r.robot.pose = {x, y, 0.5};
  r.robot.covariance = Eigen::Matrix3d::Identity() * pose_sigma * pose_sigma;
  r.robot.status = perception::LocalizationStatus::kTracking;
  r.received_utime = t;
  return r;
}

void seeBall(Report& r, double x, double y, double sigma, double vx = 0.0, double vy = 0.0) {
  r.ball.valid = true;
  r.ball.utime = r.robot.utime;
  r.ball.last_seen_utime = r.robot.utime;
  r.ball.x = x;
  r.ball.y = y;
  r.ball.vx = vx;
  r.ball.vy = vy;
  r.ball.covariance = Eigen::Matrix2d::Identity() * sigma * sigma;
}

TEST(teamcomm_picture, AgesAndPredictsTeammatesAndDropsTheSilentOnes) {
  TeamPicture picture(1);
  Report mate = report(1.0, -2.0, kT0);
  mate.robot.vx = 2.0;
  mate.robot.vy = -1.0;
  mate.robot.omega = 1.0;
  picture.setReport(3, mate);
  const perception::TeamState s = picture.picture(kT0 + 100'000);
  const perception::TeammateState& r3 = s.robots[2];
  EXPECT_TRUE(r3.present);
  EXPECT_EQ(r3.robot_age_us, 100'000);
  EXPECT_NEAR(r3.x, 1.2, 1e-9);
  EXPECT_NEAR(r3.y, -2.1, 1e-9);
  EXPECT_NEAR(r3.phi, 0.6, 1e-9);
  // sqrt(0.05^2 + (0.5 m/s * 0.1 s)^2)
  EXPECT_NEAR(r3.sigma_xy, std::sqrt(0.0025 + 0.0025), 1e-6);
  EXPECT_FALSE(s.robots[1].present);
  EXPECT_FALSE(r3.ball_valid);
  EXPECT_FALSE(s.team_ball_valid);
  // Silent for longer than the timeout: absent.
  EXPECT_FALSE(picture.picture(kT0 + 600'000).robots[2].present);
}

TEST(teamcomm_picture, FusesConsistentBallsBetterThanAnyOne) {
  TeamPicture picture(1);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.15);
  double fused_error = 0.0;
  std::array<double, 4> single_error{};
  for (int trial = 0; trial < 200; ++trial) {
    for (int id = 1; id <= 4; ++id) {
      Report r = report(id, 0.0, kT0);
      const double bx = 2.0 + noise(rng), by = 1.0 + noise(rng);
      seeBall(r, bx, by, 0.15);
      single_error[static_cast<std::size_t>(id - 1)] += std::hypot(bx - 2.0, by - 1.0);
      picture.setReport(id, r);
    }
    TeamBallResult ball;
    const auto s = picture.picture(kT0, &ball);
    ASSERT_TRUE(s.team_ball_valid);
    EXPECT_EQ(ball.used.size(), 4u);
    fused_error += std::hypot(s.team_ball_x - 2.0, s.team_ball_y - 1.0);
  }
  // Four equal robots: the fused error is about half of the best robot's mean error.
  const double best_single = *std::min_element(single_error.begin(), single_error.end());
  EXPECT_LT(fused_error, 0.6 * best_single);
}

TEST(teamcomm_picture, LeavesOutAMislocalizedTeammatesBall) {
  TeamPicture picture(2);
  for (int id : {1, 2, 3}) {
    Report r = report(0.0, id, kT0);
    seeBall(r, 3.0 + 0.02 * id, -1.0, 0.1);
    picture.setReport(id, r);
  }
  // Robot 5 thinks it is 2 m from where it is, confidently: its ball is 2 m off.
  Report lost = report(-2.0, 0.0, kT0, 0.02);
  seeBall(lost, 1.0, -1.0, 0.05);
  picture.setReport(5, lost);
  TeamBallResult ball;
  const auto s = picture.picture(kT0 + 20'000, &ball);
  ASSERT_TRUE(s.team_ball_valid);
  EXPECT_EQ(ball.used, (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(ball.rejected, (std::vector<int>{5}));
  EXPECT_NEAR(s.team_ball_x, 3.04, 0.01);
  EXPECT_NEAR(s.team_ball_y, -1.0, 1e-6);
  // Its own view of its ball is still reported, just not fused.
  EXPECT_TRUE(s.robots[4].ball_valid);
  EXPECT_NEAR(s.robots[4].ball_x, 1.0, 1e-9);
}

TEST(teamcomm_picture, UsesOnlyFreshBallsFromLocalizedRobotsAndPredictsThem) {
  TeamPicture picture(1);
  Report searching = report(0.0, 0.0, kT0);
  searching.robot.status = perception::LocalizationStatus::kSearching;
  seeBall(searching, 1.0, 1.0, 0.1);
  picture.setReport(2, searching);
  Report stale = report(0.0, 0.0, kT0);
  seeBall(stale, -1.0, 1.0, 0.1);
  stale.ball.last_seen_utime = kT0 - 1'500'000;
  picture.setReport(3, stale);
  EXPECT_FALSE(picture.picture(kT0).team_ball_valid);

  Report rolling = report(0.0, 0.0, kT0);
  seeBall(rolling, 0.0, 0.0, 0.1, 1.0, -2.0);
  picture.setReport(4, rolling);
  const auto s = picture.picture(kT0 + 200'000);
  ASSERT_TRUE(s.team_ball_valid);
  EXPECT_NEAR(s.team_ball_x, 0.2, 1e-9);
  EXPECT_NEAR(s.team_ball_y, -0.4, 1e-9);
  EXPECT_NEAR(s.team_ball_vx, 1.0, 1e-9);
  EXPECT_EQ(s.robots[3].ball_age_us, 200'000);
  // Prediction uncertainty grew: 0.1^2 + (0.3 m/s * 0.2 s)^2 (the reporter's pose uncertainty is
  // in its ball filter's covariance already, and so is the stamps' common term of a lone
  // reporter: TheStampTermOfARollingBallCountsOnce).
  EXPECT_NEAR(s.team_ball_covariance(0, 0), 0.01 + 0.0036, 1e-9);
  EXPECT_NEAR(s.team_ball_covariance(1, 1), 0.01 + 0.0036, 1e-9);
  EXPECT_NEAR(s.team_ball_covariance(0, 1), 0.0, 1e-9);
}

TEST(teamcomm_picture, ARestingBallIsPredictedWithTheRestingModel) {
  // A ball reported at rest (fusion's resting model) grows by the resting speed sigma, 3 cm/s,
  // not the rolling ball's 0.3 m/s: 0.2 s later 0.006 m, not 0.06 m. Two robots seeing it from
  // near with 5 mm sigmas: the team ball is sqrt(2) better, not held at a 2 cm floor.
  TeamPicture picture(1);
  for (int id = 2; id <= 3; ++id) {
    Report r = report(id - 3.0, 0.0, kT0);
    seeBall(r, 1.0, 1.0, 0.005, 0.05, 0.0);  // 5 cm/s: at rest
    picture.setReport(id, r);
  }
  const auto s = picture.picture(kT0 + 200'000);
  ASSERT_TRUE(s.team_ball_valid);
  const double grown = 0.03 * 0.2;
  const double one = 0.005 * 0.005 + grown * grown;
  // Each report's covariance is taken to hold the stamp term (st v)^2 along the velocity: the
  // own parts are fused, the term is held once.
  const double st = PictureOptions{}.ball_stamp_sigma_s;
  const double stamp = st * st * 0.05 * 0.05;
  EXPECT_NEAR(s.team_ball_covariance(0, 0), 0.5 * (one - stamp) + stamp, 1e-12);
  EXPECT_NEAR(s.team_ball_covariance(1, 1), 0.5 * one, 1e-12);
  // Rolling at 0.5 m/s the same report grows by 0.3 m/s.
  for (int id = 2; id <= 3; ++id) {
    Report r = report(id - 3.0, 0.0, kT0);
    seeBall(r, 1.0, 1.0, 0.005, 0.0, 0.5);
    picture.setReport(id, r);
  }
  const auto rolling = picture.picture(kT0 + 200'000);
  EXPECT_NEAR(rolling.team_ball_covariance(0, 0), 0.5 * (0.005 * 0.005 + 0.06 * 0.06), 1e-12);
}

TEST(teamcomm_picture, SaysWhichRobotsMayBeOnTheirTwinAndKeepsTheirBalls) {
  // At start-up every robot's pose is ambiguous (only the own-half prior chose it): their balls
  // still make the team ball, and the flag goes with each robot for fusion's twin vote to weigh.
  TeamPicture picture(1);
  for (int id : {2, 3}) {
    Report r = report(1.0, 0.5 * id, kT0);
    r.robot.twin_ambiguous = id == 3;
    seeBall(r, 2.0 + 0.02 * id, 1.0, 0.1);
    picture.setReport(id, r);
  }
  TeamBallResult ball;
  const perception::TeamState s = picture.picture(kT0 + 20'000, &ball);
  EXPECT_FALSE(s.robots[1].twin_ambiguous);
  EXPECT_TRUE(s.robots[2].twin_ambiguous);
  EXPECT_TRUE(s.robots[2].ball_valid);
  EXPECT_EQ(ball.used, (std::vector<int>{2, 3}));
  // A robot that is not present says nothing, the flag included.
  EXPECT_FALSE(picture.picture(kT0 + 2'000'000).robots[2].twin_ambiguous);
}

TEST(teamcomm_picture, WhenTwoDisagreeTheMoreCertainWins) {
  TeamPicture picture(1);
  Report a = report(0.0, 0.0, kT0);
  seeBall(a, 0.0, 0.0, 0.3);
  Report b = report(0.0, 0.0, kT0);
  seeBall(b, 4.0, 0.0, 0.1);
  picture.setReport(1, a);
  picture.setReport(2, b);
  TeamBallResult ball;
  picture.picture(kT0, &ball);
  EXPECT_EQ(ball.used, std::vector<int>{2});
  EXPECT_EQ(ball.rejected, std::vector<int>{1});
}

// hidden_ball: a robot standing 3-4 m from a resting ball sees it on the same pixels every frame;
// fusion's filter shrinks its covariance frame by frame, but its error is a bias along the line
// of sight that stays (2.5 cm with a 1.3 cm sigma). Its weight there is capped by the radial
// floor (PictureOptions::ball_radial_floor_per_m2), across the line of sight it still counts.
TEST(teamcomm_picture, AFarStaticViewsBiasAlongItsLineOfSightDoesNotPullTheTeamBall) {
  TeamPicture picture(1);
  Report near = report(-1.5, 0.0, kT0);
  seeBall(near, 0.0, 0.0, 0.005);
  Report far = report(4.0, 0.0, kT0);
  seeBall(far, 0.02, 0.0, 0.006);  // 2 cm short, claiming 6 mm: still inside the gate
  picture.setReport(1, near);
  picture.setReport(2, far);
  TeamBallResult ball;
  picture.picture(kT0, &ball);
  EXPECT_EQ(ball.used, (std::vector<int>{1, 2}));
  // At their claimed weights the team ball lay 8 mm towards the far robot.
  EXPECT_LT(std::abs(ball.position.x()), 0.003);
  // Across the line of sight both count: narrower than the near robot's 5 mm alone.
  EXPECT_LT(ball.covariance(1, 1), 0.8 * 0.005 * 0.005);
  // Along it, the floor: 1.5 mm per m^2 of range, 2.4 cm at 4 m.
  PictureOptions off;
  off.ball_radial_floor_per_m2 = 0.0;
  TeamPicture unfloored(1, off);
  unfloored.setReport(1, near);
  unfloored.setReport(2, far);
  unfloored.picture(kT0, &ball);
  EXPECT_GT(std::abs(ball.position.x()), 0.007);
  // A robot turning on the spot sees the ball on other pixels every frame: its filter's
  // averaging holds, no floor.
  far.robot.omega = 0.6;
  picture.setReport(2, far);
  picture.picture(kT0, &ball);
  EXPECT_GT(std::abs(ball.position.x()), 0.007);
}

// Every BALL_STATE's covariance holds the stamp error's term (fusion's ball.stamp_sigma_s times
// the velocity, along it) once; the team ball counts it once, not once more.
TEST(teamcomm_picture, TheStampTermOfARollingBallCountsOnce) {
  const Eigen::Vector2d v(3.0, 0.0);
  const double st = PictureOptions{}.ball_stamp_sigma_s;
  const Eigen::Matrix2d stamp = st * st * v * v.transpose();
  const auto rolling = [&](double y) {
    Report r = report(0.0, y, kT0);
    r.robot.vx = 1.0;  // moving: no static view
    seeBall(r, 2.0, 0.0, 0.01, v.x(), v.y());
    r.ball.covariance += stamp;
    return r;
  };
  TeamPicture alone(1);
  alone.setReport(1, rolling(0.0));
  TeamBallResult ball;
  alone.picture(kT0, &ball);
  // Lone: the reporter's own covariance (its stamp term held once), not the term again.
  EXPECT_NEAR(ball.covariance(0, 0), 0.01 * 0.01 + stamp(0, 0), 1e-6);
  // Two alike: the independent part halves, the common part stays whole.
  TeamPicture two(1);
  two.setReport(1, rolling(0.0));
  two.setReport(2, rolling(1.0));
  two.picture(kT0, &ball);
  const double fused_independent = 0.5 * 0.01 * 0.01;
  EXPECT_NEAR(ball.covariance(0, 0), fused_independent + stamp(0, 0), 0.05 * stamp(0, 0));
  EXPECT_NEAR(ball.covariance(1, 1), fused_independent, 1e-6);
}

// The stamp term is common to the reporters and says nothing about who sees the ball better: a
// near robot (1 cm) and a far one (5 cm, 4 cm off) of a ball rolling at 3 m/s are weighed by
// their own parts. Weighed with the stamp term (9 cm along the velocity with 0.03 s) the far one
// pulled the team ball 1.7 cm of the 4 towards it.
TEST(teamcomm_picture, ARollingBallIsWeighedWithoutTheCommonStampTerm) {
  PictureOptions options;
  options.ball_stamp_sigma_s = 0.03;
  const Eigen::Vector2d v(3.0, 0.0);
  const Eigen::Matrix2d stamp = 0.03 * 0.03 * v * v.transpose();
  const auto rolling = [&](double robot_x, double ball_x, double sigma) {
    Report r = report(robot_x, 0.0, kT0);
    r.robot.vx = 1.0;  // moving: no static view
    seeBall(r, ball_x, 0.0, sigma, v.x(), v.y());
    r.ball.covariance += stamp;
    return r;
  };
  TeamPicture picture(1, options);
  picture.setReport(1, rolling(1.0, 2.0, 0.01));
  picture.setReport(2, rolling(6.0, 2.04, 0.05));
  TeamBallResult ball;
  picture.picture(kT0, &ball);
  ASSERT_TRUE(ball.valid);
  ASSERT_EQ(ball.used.size(), 2u);
  // Own parts 1 cm and 5 cm: weights 25 to 1, 1.5 mm towards the far one.
  EXPECT_NEAR(ball.position.x(), 2.0 + 0.04 / 26.0, 1e-4);
  // The fused own part plus the stamp term once.
  EXPECT_NEAR(ball.covariance(0, 0), 1.0 / (1.0 / 1e-4 + 1.0 / 25e-4) + stamp(0, 0), 1e-6);
}

// twin_kidnap (config/scenarios): robot 3 is carried onto its symmetric twin, keeps its pose by
// continuity and reports the ball at its mirror image, confidently.
TEST(teamcomm_picture, ATieGoesToTheBallThatContinuesTheTeamBall) {
  TeamPicture picture(1);
  Report r1 = report(-4.5, 0.0, kT0), r2 = report(-2.0, 3.0, kT0), r3 = report(-1.5, -4.0, kT0);
  seeBall(r1, -1.5, 1.0, 0.05);
  seeBall(r2, -1.52, 1.01, 0.05);
  seeBall(r3, -1.49, 1.0, 0.05);
  for (const auto& [id, r] : {std::pair{1, r1}, {2, r2}, {3, r3}})
    picture.setReport(id, r);
  ASSERT_TRUE(picture.picture(kT0).team_ball_valid);
  // Robot 1 loses the ball; robot 3 is now on its twin, surer than robot 2.
  r1.ball.valid = false;
  seeBall(r3, 1.5, -1.0, 0.03);
  for (const auto& [id, r] : {std::pair{1, r1}, {3, r3}})
    picture.setReport(id, r);
  TeamBallResult ball;
  const perception::TeamState s = picture.picture(kT0 + 100'000, &ball);
  ASSERT_TRUE(s.team_ball_valid);
  EXPECT_EQ(ball.used, std::vector<int>{2});
  EXPECT_EQ(ball.rejected, std::vector<int>{3});
  EXPECT_EQ(ball.mirrored, std::vector<int>{3});
  // Robot 2's ball, or the resting team ball of three robots carried (carry_track).
  EXPECT_NEAR(s.team_ball_x, -1.51, 0.011);
}

TEST(teamcomm_picture, ALoneBallAtTheTeamBallsMirrorImageIsLeftOut) {
  TeamPicture picture(1);
  Report r1 = report(-4.5, 0.0, kT0), r3 = report(-1.5, -4.0, kT0);
  seeBall(r1, -1.5, 1.0, 0.05);
  picture.setReport(1, r1);
  ASSERT_TRUE(picture.picture(kT0).team_ball_valid);
  // Only robot 3 sees the ball now, from its twin.
  r1.ball.valid = false;
  picture.setReport(1, r1);
  seeBall(r3, 1.5, -1.0, 0.05);
  picture.setReport(3, r3);
  TeamBallResult ball;
  EXPECT_FALSE(picture.picture(kT0 + 200'000, &ball).team_ball_valid);
  EXPECT_EQ(ball.rejected, std::vector<int>{3});
  EXPECT_EQ(ball.mirrored, std::vector<int>{3});
  // A lone ball elsewhere (a kick) is the team ball at once.
  Report r2 = report(-2.0, 3.0, kT0 + 300'000);
  seeBall(r2, 0.5, 3.0, 0.05);
  picture.setReport(3, report(-1.5, -4.0, kT0 + 300'000));
  picture.setReport(2, r2);
  EXPECT_TRUE(picture.picture(kT0 + 300'000).team_ball_valid);
}

TEST(teamcomm_picture, AMirroredBallIsTheTeamBallOnceThePreviousOneIsOld) {
  TeamPicture picture(1);
  Report r1 = report(-4.5, 0.0, kT0);
  seeBall(r1, -1.5, 1.0, 0.05);
  picture.setReport(1, r1);
  ASSERT_TRUE(picture.picture(kT0).team_ball_valid);
  // Nothing for longer than the previous team ball is trusted (3 s): a lone report is all there is.
  const Utime later = kT0 + 3'500'000;
  Report r3 = report(-1.5, -4.0, later);
  seeBall(r3, 1.5, -1.0, 0.05);
  picture.setReport(3, r3);
  EXPECT_TRUE(picture.picture(later).team_ball_valid);
}

TEST(teamcomm_picture, BallsSeenBeforeAFresherContradictingSightingAreSuperseded) {
  TeamPicture picture(1);
  // Robots 1 and 2 saw the ball at (-1.5, 1) until 300 ms ago (their estimates still valid);
  // robot 3 sees it now 3 m away: it was kicked. Robot 4 last saw it 300 ms ago where robot 3
  // sees it now (it agrees: kept).
  const Utime now = kT0 + 300'000;
  Report r1 = report(-4.5, 0.0, now), r2 = report(-2.0, 3.0, now), r3 = report(1.0, -3.0, now),
         r4 = report(4.0, 0.0, now);
  seeBall(r1, -1.5, 1.0, 0.05);
  seeBall(r2, -1.52, 1.01, 0.05);
  seeBall(r3, 1.5, -1.0, 0.05);
  seeBall(r4, 1.52, -1.0, 0.05);
  r1.ball.last_seen_utime = r2.ball.last_seen_utime = r4.ball.last_seen_utime = kT0;
  for (const auto& [id, r] : {std::pair{1, r1}, {2, r2}, {3, r3}, {4, r4}})
    picture.setReport(id, r);
  TeamBallResult ball;
  const perception::TeamState s = picture.picture(now, &ball);
  ASSERT_TRUE(s.team_ball_valid);
  EXPECT_EQ(ball.used, (std::vector<int>{3, 4}));
  EXPECT_EQ(ball.rejected, (std::vector<int>{1, 2}));
  EXPECT_EQ(ball.superseded, (std::vector<int>{1, 2}));
  EXPECT_NEAR(s.team_ball_x, 1.51, 1e-6);
  // Seen within a frame and a packet interval of the fresh one: a plain disagreement, the
  // larger group wins as before.
  r1.ball.last_seen_utime = r2.ball.last_seen_utime = now - 80'000;
  r4.ball.valid = false;
  for (const auto& [id, r] : {std::pair{1, r1}, {2, r2}, {4, r4}})
    picture.setReport(id, r);
  const perception::TeamState t = picture.picture(now, &ball);
  EXPECT_TRUE(ball.superseded.empty());
  EXPECT_EQ(ball.used, (std::vector<int>{1, 2}));
  EXPECT_NEAR(t.team_ball_x, -1.51, 1e-6);
}

TEST(teamcomm_picture, ABallNobodyHasSeenForLongerThanFusionsMaxAgeIsNotClaimed) {
  TeamPicture picture(1);
  // Robot 2's packet still calls its ball valid, but it last saw it 0.6 s ago: longer than
  // fusion's own-ball limit (ball.max_age_s 0.5), so the team does not know the ball either.
  const Utime now = kT0 + 600'000;
  Report r2 = report(0.0, 0.0, now);
  seeBall(r2, 1.0, 1.0, 0.05);
  r2.ball.last_seen_utime = kT0;
  picture.setReport(2, r2);
  EXPECT_FALSE(picture.picture(now).team_ball_valid);
  r2.ball.last_seen_utime = now - 400'000;
  picture.setReport(2, r2);
  EXPECT_TRUE(picture.picture(now).team_ball_valid);
}

TEST(teamcomm_picture, APutBackSeenByOneConfidentRobotMovesTheTeamBallWithinOneUpdate) {
  TeamPicture picture(1);
  Report r1 = report(-4.5, 0.0, kT0), r2 = report(-2.0, 3.0, kT0), r3 = report(1.0, -3.0, kT0);
  seeBall(r1, -1.5, 1.0, 0.05);
  seeBall(r2, -1.52, 1.01, 0.05);
  picture.setReport(1, r1);
  picture.setReport(2, r2);
  ASSERT_NEAR(picture.picture(kT0).team_ball_x, -1.51, 1e-6);
  // The ball is put back at (2, -2). Robots 1 and 2 no longer see it (their estimates stay valid
  // at the old place); robot 3's filter restarts at the new place after three frames (100 ms).
  const Utime now = kT0 + 100'000;
  r1.robot.utime = r2.robot.utime = r1.received_utime = r2.received_utime = now;
  r3 = report(1.0, -3.0, now);
  seeBall(r3, 2.0, -2.0, 0.05);
  picture.setReport(1, r1);
  picture.setReport(2, r2);
  picture.setReport(3, r3);
  TeamBallResult ball;
  const perception::TeamState s = picture.picture(now, &ball);
  ASSERT_TRUE(s.team_ball_valid);
  EXPECT_NEAR(s.team_ball_x, 2.0, 1e-6);
  EXPECT_NEAR(s.team_ball_y, -2.0, 1e-6);
  EXPECT_EQ(ball.superseded, (std::vector<int>{1, 2}));
  // A vague sighting (30 cm) there supersedes nothing: the two agreeing robots keep the ball.
  seeBall(r3, 2.0, -2.0, 0.3);
  picture.setReport(3, r3);
  const perception::TeamState t = picture.picture(now, &ball);
  EXPECT_TRUE(ball.superseded.empty());
  EXPECT_NEAR(t.team_ball_x, -1.51, 1e-6);
}

// A resting ball seen from 1 m, then only by a robot 5 m away whose ball is 6 cm off (within
// its 5 cm sigma): the team ball keeps the near robot's place (its sigma grown by the carry)
// instead of jumping to the far robot's.
TEST(teamcomm_picture, ARestingBallSeenNearIsCarriedWhenOnlyAFarRobotSeesIt) {
  TeamPicture picture(1);
  Utime now = kT0;
  for (int i = 0; i < 10; ++i, now += 100'000) {
    Report near = report(1.0, 1.0, now);
    seeBall(near, 2.0, 1.0, 0.01);
    picture.setReport(2, near);
    ASSERT_TRUE(picture.picture(now).team_ball_valid);
  }
  picture.clear(2);
  Report far = report(-3.0, 1.0, now);
  seeBall(far, 2.06, 1.0, 0.05);
  picture.setReport(5, far);
  TeamBallResult ball;
  const perception::TeamState s = picture.picture(now, &ball);
  ASSERT_TRUE(s.team_ball_valid);
  EXPECT_EQ(ball.used, (std::vector<int>{5}));
  EXPECT_NEAR(s.team_ball_x, 2.0, 0.005);
  EXPECT_NEAR(s.team_ball_y, 1.0, 0.005);
  // Never more confident than the carried ball: 1 cm grown by 0.1 m/s over 0.1 s.
  EXPECT_GE(s.team_ball_covariance(0, 0), 0.01 * 0.01 + 0.01 * 0.01 - 1e-9);
  // Carried for as long as it stays the better one: its sigma grows, the far ball takes over.
  for (int i = 0; i < 30; ++i) {
    now += 100'000;
    far = report(-3.0, 1.0, now);
    seeBall(far, 2.06, 1.0, 0.05);
    picture.setReport(5, far);
    picture.picture(now);
  }
  EXPECT_GT(picture.picture(now).team_ball_x, 2.04);
}

// The far robot's ball contradicts the carried one (the ball was moved) or rolls: not carried.
TEST(teamcomm_picture, AContradictedOrRollingBallIsNotCarried) {
  for (const bool rolling : {false, true}) {
    TeamPicture picture(1);
    Report near = report(1.0, 1.0, kT0);
    seeBall(near, 2.0, 1.0, 0.01);
    picture.setReport(2, near);
    ASSERT_TRUE(picture.picture(kT0).team_ball_valid);
    picture.clear(2);
    const Utime now = kT0 + 100'000;
    Report far = report(-3.0, 1.0, now);
    if (rolling) {
      seeBall(far, 2.06, 1.0, 0.05, 0.5, 0.0);
    } else {
      seeBall(far, 2.5, 1.0, 0.05);
    }
    picture.setReport(5, far);
    const perception::TeamState s = picture.picture(now);
    ASSERT_TRUE(s.team_ball_valid);
    EXPECT_NEAR(s.team_ball_x, rolling ? 2.06 : 2.5, 1e-9) << (rolling ? "rolling" : "moved");
  }
}

// Only sightings the picture's group does not hold are carried: a robot's newer estimate has its
// older ones in it (its filter), even when the older one claimed to be surer (a filter starting).
TEST(teamcomm_picture, ARobotsOwnEarlierBallIsNotCarriedOverItsNewerOne) {
  TeamPicture picture(1);
  Report far = report(-3.0, 1.0, kT0);
  seeBall(far, 2.1, 1.0, 0.01);
  picture.setReport(5, far);
  ASSERT_TRUE(picture.picture(kT0).team_ball_valid);
  const Utime now = kT0 + 100'000;
  far = report(-3.0, 1.0, now);
  seeBall(far, 2.0, 1.0, 0.04);
  picture.setReport(5, far);
  EXPECT_NEAR(picture.picture(now).team_ball_x, 2.0, 1e-9);
}

TEST(teamcomm_team_state, MessageCarriesEveryField) {
  perception::TeamState s;
  s.utime = kT0;
  for (int i = 0; i < perception::kTeamSize; ++i) {
    auto& r = s.robots[static_cast<std::size_t>(i)];
    r.present = i % 2 == 0;
    r.x = i + 0.1;
    r.y = -i - 0.2;
    r.phi = 0.3 * i;
    r.sigma_xy = 0.01f * static_cast<float>(i);
    r.robot_age_us = 1000 * i;
    r.ball_valid = i % 3 == 0;
    r.ball_x = 0.5 * i;
    r.ball_y = -0.5 * i;
    r.ball_age_us = 2000 * i;
    r.clock_offset_us = -300'000 + i;
    r.round_trip_us = 4000 + i;
    r.packets_received = 100 * i;
    r.packets_rejected = 7 * i;
    r.twin_ambiguous = i % 2 == 1;
  }
  s.team_ball_valid = true;
  s.team_ball_x = 1.5;
  s.team_ball_y = -2.5;
  s.team_ball_vx = 0.25;
  s.team_ball_vy = -0.75;
  s.team_ball_covariance << 0.04, 0.01, 0.01, 0.09;
  team_state_t m;
  msg::toMessage(s, m);
  EXPECT_EQ(m.num_robots, 6);
  const perception::TeamState back = msg::fromMessage(m);
  EXPECT_EQ(back.utime, s.utime);
  for (std::size_t i = 0; i < 6; ++i) {
    const auto &a = s.robots[i], &b = back.robots[i];
    EXPECT_EQ(a.present, b.present);
    EXPECT_EQ(a.x, b.x);
    EXPECT_EQ(a.y, b.y);
    EXPECT_EQ(a.phi, b.phi);
    EXPECT_EQ(a.sigma_xy, b.sigma_xy);
    EXPECT_EQ(a.robot_age_us, b.robot_age_us);
    EXPECT_EQ(a.ball_valid, b.ball_valid);
    EXPECT_EQ(a.ball_x, b.ball_x);
    EXPECT_EQ(a.ball_y, b.ball_y);
    EXPECT_EQ(a.ball_age_us, b.ball_age_us);
    EXPECT_EQ(a.clock_offset_us, b.clock_offset_us);
    EXPECT_EQ(a.round_trip_us, b.round_trip_us);
    EXPECT_EQ(a.packets_received, b.packets_received);
    EXPECT_EQ(a.packets_rejected, b.packets_rejected);
    EXPECT_EQ(a.twin_ambiguous, b.twin_ambiguous);
  }
  EXPECT_EQ(back.team_ball_valid, true);
  EXPECT_EQ(back.team_ball_x, 1.5);
  EXPECT_EQ(back.team_ball_y, -2.5);
  EXPECT_EQ(back.team_ball_vx, 0.25);
  EXPECT_EQ(back.team_ball_vy, -0.75);
  EXPECT_EQ(back.team_ball_covariance, s.team_ball_covariance);
  // A short message leaves the missing robots absent instead of reading past its arrays.
  m.num_robots = 2;
  m.present.resize(2);
  const perception::TeamState cut = msg::fromMessage(m);
  EXPECT_TRUE(cut.robots[0].present);
  EXPECT_FALSE(cut.robots[2].present);
}

// The team picture takes fusion's stamp term out of every BALL_STATE: a value unlike fusion's
// weighs the reporters wrong, and the clamp at min_ball_variance would hide it (review 13).
TEST(TeamPictureSettings, TheStampSigmaIsFusionsBallStampSigma) {
  EXPECT_EQ(PictureOptions{}.ball_stamp_sigma_s, fusion::BallFilterParams{}.stamp_sigma_s);
  const double fusion_shipped = config::Node::loadFile(config::resolvePreset("fusion", "default"))
                                    .child("ball")
                                    .get<double>("stamp_sigma_s");
  const TeamcommConfig team =
      loadTeamcommConfig(config::Node::loadFile(config::resolvePreset("team", "sim_team")));
  EXPECT_EQ(team.node.picture.ball_stamp_sigma_s, fusion_shipped)
      << "config/team/sim_team.yaml's team.picture.ball_stamp_sigma_s differs from "
         "config/fusion/default.yaml's ball.stamp_sigma_s";
}

}  // namespace team_picture_test
}  // namespace fieldline::teamcomm
