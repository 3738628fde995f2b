// Teammates' balls vote on the field's twin: same half, twin, or no say (near the centre spot,
// too few teammates, a split team, stale balls, an unsure sighting, a picture that already
// voted), and refused team pictures are counted and change nothing.
#include "services/fusion/team_twin.hpp"

#include <limits>
#include <stdexcept>

#include <gtest/gtest.h>

namespace fieldline::fusion {
namespace team_twin_test {

constexpr Utime kT = 1'800'000'000'000'000;
constexpr double kSigma = 0.05;  // a sure sighting

// A team picture at `utime` in which robots `ids` (1..6) see the ball at `ball`.
perception::TeamState teamSeeing(const Eigen::Vector2d& ball, std::initializer_list<int> ids,
                                 Utime utime = kT) {
  perception::TeamState team;
  team.utime = utime;
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
  // Neither: our ball is somewhere else (a false sighting, or theirs).
  EXPECT_EQ(voter.vote({0.0, 3.5}, kSigma, kT, false), TwinVote::kNone);
  EXPECT_EQ(voter.vote(ball + Eigen::Vector2d(0.2, 0.1), kSigma, kT, false), TwinVote::kSame);
  // One vote per picture: the teammates' evidence is the same until the next one.
  EXPECT_EQ(voter.vote(ball, kSigma, kT + 30'000, false), TwinVote::kNone);
  // Seen from the twin our ball lands at minus where they see it. (The agreements just made
  // count for the window, so they are forgotten first: the pose changed.)
  voter.clearEvidence();
  voter.setTeam(teamSeeing(ball, {2, 4}, kT + 100'000));
  EXPECT_EQ(voter.vote(-ball, kSigma, kT + 100'000, false), TwinVote::kTwin);
  // A teammate's newer agreement replaces its older one.
  voter.setTeam(teamSeeing(ball, {2, 4}, kT + 200'000));
  EXPECT_EQ(voter.vote(ball, kSigma, kT + 200'000, false), TwinVote::kSame);
  // A sighting less sure than max_sighting_sigma_m has no say.
  voter.setTeam(teamSeeing(ball, {2, 4}, kT + 300'000));
  EXPECT_EQ(voter.vote(ball, 0.4, kT + 300'000, false), TwinVote::kNone);
  EXPECT_EQ(voter.vote(ball, std::numeric_limits<double>::quiet_NaN(), kT + 300'000, false),
            TwinVote::kNone);
}

TEST(TeamBallVoter, TeammatesWhoSeeTheBallInTurnAddUpWithinTheWindow) {
  TeamBallVoter voter(1);
  const Eigen::Vector2d ball(-1.5, 1.0);
  // Robot 2 sees it, then only robot 3 (they block each other's view): neither picture alone has
  // two teammates, the window has.
  voter.setTeam(teamSeeing(ball, {2}));
  EXPECT_EQ(voter.vote(-ball, kSigma, kT, false), TwinVote::kNone);
  voter.setTeam(teamSeeing(ball, {3}, kT + 1'500'000));
  EXPECT_EQ(voter.vote(-ball, kSigma, kT + 1'500'000, false), TwinVote::kTwin);
  // Beyond the window robot 2's agreement is forgotten.
  voter.setTeam(teamSeeing(ball, {3}, kT + 2'500'000));
  EXPECT_EQ(voter.vote(-ball, kSigma, kT + 2'500'000, false), TwinVote::kNone);
  // A sighting that agrees with no teammate has no say, whatever the window holds.
  voter.setTeam(teamSeeing(ball, {2, 3}, kT + 2'600'000));
  EXPECT_EQ(voter.vote({4.0, -3.0}, kSigma, kT + 2'600'000, false), TwinVote::kNone);
}

TEST(TeamBallVoter, OnlyTeammatesSureOfTheirPosesCanDoubtACertainPose) {
  const Eigen::Vector2d ball(3.0, -1.0);
  // Robots 2 and 3 may be on their own twins (their ROBOT_STATE says twin_ambiguous): they see
  // the ball mirrored, at -ball, where our certain pose puts it at +ball.
  perception::TeamState unsure = teamSeeing(-ball, {2, 3});
  unsure.robots[1].twin_ambiguous = unsure.robots[2].twin_ambiguous = true;
  TeamBallVoter certain(1);
  certain.setTeam(unsure);
  EXPECT_EQ(certain.vote(ball, kSigma, kT, /*pose_certain=*/true), TwinVote::kNone);
  // An ambiguous pose hears them (at start-up every robot is ambiguous, and they confirm or move
  // each other with their balls).
  TeamBallVoter ambiguous(1);
  ambiguous.setTeam(unsure);
  EXPECT_EQ(ambiguous.vote(ball, kSigma, kT, /*pose_certain=*/false), TwinVote::kTwin);
  // Teammates sure of their poses can doubt a certain one (the localizer then needs two runs).
  certain.setTeam(teamSeeing(-ball, {2, 3}, kT + 100'000));
  EXPECT_EQ(certain.vote(ball, kSigma, kT + 100'000, true), TwinVote::kTwin);
  // The flag is judged as it was at each agreement: a teammate unsure then does not count for a
  // certain pose later in the window, one sure then does.
  TeamBallVoter mixed(1);
  perception::TeamState first = teamSeeing(-ball, {2});
  first.robots[1].twin_ambiguous = true;
  mixed.setTeam(first);
  EXPECT_EQ(mixed.vote(ball, kSigma, kT, true), TwinVote::kNone);
  mixed.setTeam(teamSeeing(-ball, {3}, kT + 500'000));
  EXPECT_EQ(mixed.vote(ball, kSigma, kT + 500'000, true), TwinVote::kNone);  // robot 3 alone
  mixed.setTeam(teamSeeing(-ball, {4}, kT + 900'000));
  EXPECT_EQ(mixed.vote(ball, kSigma, kT + 900'000, true), TwinVote::kTwin);  // robots 3 and 4
  // A teammate unsure of its own pose that sees the ball where we do still counts for us: three
  // such veto two sure teammates that see it mirrored.
  TeamBallVoter vetoed(1);
  perception::TeamState with = teamSeeing(ball, {2, 3, 4});
  for (const std::size_t k : {1u, 2u, 3u})
    with.robots[k].twin_ambiguous = true;
  const perception::TeamState against = teamSeeing(-ball, {5, 6}, kT + 100'000);
  vetoed.setTeam(with);
  EXPECT_EQ(vetoed.vote(ball, kSigma, kT, true), TwinVote::kSame);
  vetoed.setTeam(against);
  EXPECT_EQ(vetoed.vote(ball, kSigma, kT + 100'000, true), TwinVote::kNone);
}

TEST(TeamBallVoter, NoSayNearTheCentreWithOneTeammateOrASplitTeam) {
  TeamBallVoter voter(1);
  // Near the centre spot a ball and its mirror image are within reach of one another.
  voter.setTeam(teamSeeing({0.4, 0.3}, {2, 3, 4}));
  EXPECT_EQ(voter.vote({0.4, 0.3}, kSigma, kT, false), TwinVote::kNone);
  // One teammate alone does not decide.
  TeamBallVoter alone(1);
  alone.setTeam(teamSeeing({3.0, 1.0}, {2}));
  EXPECT_EQ(alone.vote({3.0, 1.0}, kSigma, kT, false), TwinVote::kNone);
  // Our own entry (robot 1) is not a teammate.
  TeamBallVoter self(1);
  self.setTeam(teamSeeing({3.0, 1.0}, {1, 2}));
  EXPECT_EQ(self.vote({3.0, 1.0}, kSigma, kT, false), TwinVote::kNone);
  // Two for one side and one for the other (a teammate on its own twin): no clear majority.
  TeamBallVoter split_voter(1);
  perception::TeamState split = teamSeeing({3.0, 1.0}, {2, 3});
  split.robots[4] = split.robots[1];
  split.robots[4].ball_x = -3.0;
  split.robots[4].ball_y = -1.0;
  split_voter.setTeam(split);
  EXPECT_EQ(split_voter.vote({3.0, 1.0}, kSigma, kT, false), TwinVote::kNone);
  // Three to one is.
  split.robots[5] = split.robots[1];
  split.utime = kT + 100'000;
  split_voter.setTeam(split);
  EXPECT_EQ(split_voter.vote({3.0, 1.0}, kSigma, kT + 100'000, false), TwinVote::kSame);
}

TEST(TeamBallVoter, StaleBallsAndDistantPicturesHaveNoSay) {
  TeamBallVoter voter(1);
  perception::TeamState team = teamSeeing({3.0, 1.0}, {2, 3});
  team.robots[2].ball_age_us = 900'000;  // over max_ball_age_us
  voter.setTeam(team);
  EXPECT_EQ(voter.vote({3.0, 1.0}, kSigma, kT, false), TwinVote::kNone);
  TeamBallVoter fresh(1);
  fresh.setTeam(teamSeeing({3.0, 1.0}, {2, 3}));
  EXPECT_EQ(fresh.vote({3.0, 1.0}, kSigma, kT + 400'000, false), TwinVote::kNone);
  EXPECT_EQ(fresh.vote({3.0, 1.0}, kSigma, kT + 100'000, false), TwinVote::kSame);
}

TEST(TeamBallVoter, CarriesTheTeammatesBallsWithTheTeamBallsVelocity) {
  TeamBallVoter voter(1);
  perception::TeamState team = teamSeeing({3.0, 1.0}, {2, 3});
  team.team_ball_valid = true;
  team.team_ball_vx = -4.0;  // a kicked ball: 0.8 m in the 0.2 s to our sighting
  voter.setTeam(team);
  EXPECT_EQ(voter.vote({3.0, 1.0}, kSigma, kT + 200'000, false), TwinVote::kNone);
  EXPECT_EQ(voter.vote({2.2, 1.0}, kSigma, kT + 200'000, false), TwinVote::kSame);
}

TEST(TeamBallVoter, RefusesBadPicturesCountsThemAndChangesNothing) {
  TeamBallVoter voter(1);
  voter.setTeam(teamSeeing({3.0, 1.0}, {2, 3}));
  // An older picture after a newer one: refused, the newer one stays.
  voter.setTeam(teamSeeing({-3.0, -1.0}, {2, 3}, kT - 1));
  EXPECT_EQ(voter.refusals().at("team_state_out_of_order"), 1u);
  EXPECT_EQ(voter.vote({3.0, 1.0}, kSigma, kT, false), TwinVote::kSame);
  // A NaN ball and a negative age are left out and counted; the others still vote.
  perception::TeamState bad = teamSeeing({3.0, 1.0}, {2, 3, 4, 5}, kT + 100'000);
  bad.robots[3].ball_x = std::numeric_limits<double>::quiet_NaN();
  bad.robots[4].ball_age_us = -5;
  bad.team_ball_valid = true;
  bad.team_ball_vx = std::numeric_limits<double>::infinity();
  voter.setTeam(bad);
  EXPECT_EQ(voter.refusals().at("team_ball_not_finite"), 1u);
  EXPECT_EQ(voter.refusals().at("team_ball_age_negative"), 1u);
  EXPECT_EQ(voter.refusals().at("team_velocity_not_finite"), 1u);
  EXPECT_EQ(voter.teammateBalls(kT + 150'000).size(), 2u);
  EXPECT_EQ(voter.teammateBalls(kT + 150'000)[0], Eigen::Vector2d(3.0, 1.0));  // not carried
  EXPECT_EQ(voter.vote({3.0, 1.0}, kSigma, kT + 100'000, false), TwinVote::kSame);
  // And our own NaN has no say.
  EXPECT_EQ(
      voter.vote({std::numeric_limits<double>::quiet_NaN(), 1.0}, kSigma, kT + 100'000, false),
      TwinVote::kNone);
}

TEST(TeamBallVoter, RefusesBadSettingsAndRobotIds) {
  TeamBallVoteParams p;
  p.agree_m = 1.2;
  p.min_centre_distance_m = 1.0;  // one ball could agree with both sides
  EXPECT_THROW(TeamBallVoter(1, p), std::invalid_argument);
  EXPECT_THROW(TeamBallVoter(0), std::invalid_argument);  // our own entry would be a teammate
  EXPECT_THROW(TeamBallVoter(7), std::invalid_argument);
  EXPECT_NO_THROW(TeamBallVoter(6));
}

}  // namespace team_twin_test
}  // namespace fieldline::fusion
