// Teammates' balls vote on the field's twin: same half, twin, or no say (near the centre spot,
// too few teammates, a split team, stale balls), and refused team pictures change nothing.
#include "services/fusion/team_twin.hpp"

#include <limits>
#include <stdexcept>

#include <gtest/gtest.h>

namespace fieldline::fusion {
namespace {

constexpr Utime kT = 1'800'000'000'000'000;

// A team picture at kT in which robots `ids` (1..6) see the ball at `ball`.
perception::TeamState teamSeeing(const Eigen::Vector2d& ball, std::initializer_list<int> ids) {
  perception::TeamState team;
  team.utime = kT;
  for (const int id : ids) {
    perception::TeammateState& r = team.robots[static_cast<std::size_t>(id - 1)];
    r.present = true;
    r.ball_valid = true;
    r.ball_x = ball.x();
    r.ball_y = ball.y();
    r.ball_age_us = 100'000;
  }
  return team;
}

TEST(TeamBallVoter, TwoTeammatesTellTheHalf) {
  TeamBallVoter voter(1);
  const Eigen::Vector2d ball(3.0, -1.0);
  voter.setTeam(teamSeeing(ball, {2, 4}));
  EXPECT_EQ(voter.vote(ball + Eigen::Vector2d(0.2, 0.1), kT), TwinVote::kSame);
  // Neither: our ball is somewhere else (a false sighting, or theirs).
  EXPECT_EQ(voter.vote({0.0, 3.5}, kT), TwinVote::kNone);
  // Seen from the twin our ball lands at minus where they see it. (The agreements just made
  // count for the window, so they are forgotten first: the pose changed.)
  voter.clearEvidence();
  EXPECT_EQ(voter.vote(-ball, kT), TwinVote::kTwin);
  // A teammate's newer agreement replaces its older one.
  EXPECT_EQ(voter.vote(ball, kT + 10'000), TwinVote::kSame);
}

TEST(TeamBallVoter, TeammatesWhoSeeTheBallInTurnAddUpWithinTheWindow) {
  TeamBallVoter voter(1);
  const Eigen::Vector2d ball(-1.5, 1.0);
  // Robot 2 sees it, then only robot 3 (they block each other's view): neither picture alone has
  // two teammates, the window has.
  voter.setTeam(teamSeeing(ball, {2}));
  EXPECT_EQ(voter.vote(-ball, kT), TwinVote::kNone);
  perception::TeamState later = teamSeeing(ball, {3});
  later.utime = kT + 1'500'000;
  voter.setTeam(later);
  EXPECT_EQ(voter.vote(-ball, kT + 1'500'000), TwinVote::kTwin);
  // Beyond the window robot 2's agreement is forgotten.
  later.utime = kT + 2'500'000;
  voter.setTeam(later);
  EXPECT_EQ(voter.vote(-ball, kT + 2'500'000), TwinVote::kNone);
  // A sighting that agrees with no teammate has no say, whatever the window holds.
  later.utime = kT + 2'600'000;
  voter.setTeam(later);
  EXPECT_EQ(voter.vote({4.0, -3.0}, kT + 2'600'000), TwinVote::kNone);
}

TEST(TeamBallVoter, NoSayNearTheCentreWithOneTeammateOrASplitTeam) {
  TeamBallVoter voter(1);
  // Near the centre spot a ball and its mirror image are within reach of one another.
  voter.setTeam(teamSeeing({0.4, 0.3}, {2, 3, 4}));
  EXPECT_EQ(voter.vote({0.4, 0.3}, kT), TwinVote::kNone);
  // One teammate alone does not decide.
  voter.setTeam(teamSeeing({3.0, 1.0}, {2}));
  EXPECT_EQ(voter.vote({3.0, 1.0}, kT), TwinVote::kNone);
  // Our own entry (robot 1) is not a teammate.
  voter.setTeam(teamSeeing({3.0, 1.0}, {1, 2}));
  EXPECT_EQ(voter.vote({3.0, 1.0}, kT), TwinVote::kNone);
  // Two for one side and one for the other (a teammate on its own twin): no clear majority.
  perception::TeamState split = teamSeeing({3.0, 1.0}, {2, 3});
  split.robots[4] = split.robots[1];
  split.robots[4].ball_x = -3.0;
  split.robots[4].ball_y = -1.0;
  voter.setTeam(split);
  EXPECT_EQ(voter.vote({3.0, 1.0}, kT), TwinVote::kNone);
  // Three to one is.
  split.robots[5] = split.robots[1];
  voter.setTeam(split);
  EXPECT_EQ(voter.vote({3.0, 1.0}, kT), TwinVote::kSame);
}

TEST(TeamBallVoter, StaleBallsAndDistantPicturesHaveNoSay) {
  TeamBallVoter voter(1);
  perception::TeamState team = teamSeeing({3.0, 1.0}, {2, 3});
  team.robots[2].ball_age_us = 900'000;  // over max_ball_age_us
  voter.setTeam(team);
  EXPECT_EQ(voter.vote({3.0, 1.0}, kT), TwinVote::kNone);
  voter.setTeam(teamSeeing({3.0, 1.0}, {2, 3}));
  EXPECT_EQ(voter.vote({3.0, 1.0}, kT + 400'000), TwinVote::kNone);
  EXPECT_EQ(voter.vote({3.0, 1.0}, kT + 100'000), TwinVote::kSame);
}

TEST(TeamBallVoter, CarriesTheTeammatesBallsWithTheTeamBallsVelocity) {
  TeamBallVoter voter(1);
  perception::TeamState team = teamSeeing({3.0, 1.0}, {2, 3});
  team.team_ball_valid = true;
  team.team_ball_vx = -4.0;  // a kicked ball: 0.8 m in the 0.2 s to our sighting
  voter.setTeam(team);
  EXPECT_EQ(voter.vote({2.2, 1.0}, kT + 200'000), TwinVote::kSame);
  EXPECT_EQ(voter.vote({3.0, 1.0}, kT + 200'000), TwinVote::kNone);
}

TEST(TeamBallVoter, RefusesBadPicturesCountsThemAndChangesNothing) {
  TeamBallVoter voter(1);
  voter.setTeam(teamSeeing({3.0, 1.0}, {2, 3}));
  // An older picture after a newer one: refused, the newer one stays.
  perception::TeamState old = teamSeeing({-3.0, -1.0}, {2, 3});
  old.utime = kT - 1;
  voter.setTeam(old);
  EXPECT_EQ(voter.refusals().at("team_state_out_of_order"), 1u);
  EXPECT_EQ(voter.vote({3.0, 1.0}, kT), TwinVote::kSame);
  // A NaN ball is left out and counted; the others still vote.
  perception::TeamState nan = teamSeeing({3.0, 1.0}, {2, 3, 4});
  nan.robots[3].ball_x = std::numeric_limits<double>::quiet_NaN();
  voter.setTeam(nan);
  EXPECT_EQ(voter.refusals().at("team_ball_not_finite"), 1u);
  EXPECT_EQ(voter.teammateBalls(kT).size(), 2u);
  EXPECT_EQ(voter.vote({3.0, 1.0}, kT), TwinVote::kSame);
  // And our own NaN has no say.
  EXPECT_EQ(voter.vote({std::numeric_limits<double>::quiet_NaN(), 1.0}, kT), TwinVote::kNone);
}

TEST(TeamBallVoter, RefusesSettingsWhereOneBallAgreesWithBothSides) {
  TeamBallVoteParams p;
  p.agree_m = 1.2;
  p.min_centre_distance_m = 1.0;
  EXPECT_THROW(TeamBallVoter(1, p), std::invalid_argument);
}

}  // namespace
}  // namespace fieldline::fusion
