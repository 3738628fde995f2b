// fieldline-eval's fault scenarios (issue 34 item 3, issue 32 item 2): the --fault syntax is
// parsed or refused with the reason, and the scoring finds each fault's time to recover, its
// largest error while TRACKING and the run's share of time not TRACKING.
#include "tools/eval/faults.hpp"

#include <algorithm>
#include <stdexcept>

#include <gtest/gtest.h>

namespace fieldline::eval {
namespace {

constexpr int kSearching = 1;
constexpr int kTracking = 2;

// parseFault's refusal of `text` ("accepted" when it takes it).
std::string refusalOf(const std::string& text) {
  try {
    parseFault(text);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "accepted";
}

TEST(EvalFaults, ParsesEachKind) {
  const FaultSpec restart = parseFault("restart:fusion/2@20");
  EXPECT_EQ(restart.kind, FaultSpec::Kind::kRestart);
  EXPECT_EQ(restart.process, "fusion");
  EXPECT_EQ(restart.robot, 2);
  EXPECT_DOUBLE_EQ(restart.at_s, 20.0);
  const FaultSpec sim = parseFault("restart:world_sim@30.5");
  EXPECT_EQ(sim.process, "world_sim");
  EXPECT_EQ(sim.robot, 0);
  EXPECT_DOUBLE_EQ(sim.at_s, 30.5);
  const FaultSpec kill = parseFault("kill:camera@12");
  EXPECT_EQ(kill.kind, FaultSpec::Kind::kKill);
  EXPECT_EQ(kill.robot, 0);  // every robot's camera
  const FaultSpec stall = parseFault("stall:3@20+1.5");
  EXPECT_EQ(stall.kind, FaultSpec::Kind::kStall);
  EXPECT_EQ(stall.robot, 3);
  EXPECT_DOUBLE_EQ(stall.duration_s, 1.5);
  EXPECT_EQ(parseFault("stall:all@25+2").robot, 0);
}

TEST(EvalFaults, ParsesClockStepsAheadAndBehind) {
  const FaultSpec ahead = parseFault("clockstep:1@20+2");
  EXPECT_EQ(ahead.kind, FaultSpec::Kind::kClockStep);
  EXPECT_EQ(ahead.robot, 1);
  EXPECT_DOUBLE_EQ(ahead.at_s, 20.0);
  EXPECT_DOUBLE_EQ(ahead.step_s, 2.0);
  EXPECT_TRUE(ahead.process.empty());
  const FaultSpec behind = parseFault("clockstep:6@7.5-0.25");
  EXPECT_EQ(behind.robot, 6);
  EXPECT_DOUBLE_EQ(behind.at_s, 7.5);
  EXPECT_DOUBLE_EQ(behind.step_s, -0.25);
}

TEST(EvalFaults, RefusesClockStepsItCannotMakeAndSaysWhy) {
  EXPECT_NE(refusalOf("clockstep:1@20").find("needs its size"), std::string::npos);
  EXPECT_NE(refusalOf("clockstep:all@20+2").find("one robot's clock"), std::string::npos);
  EXPECT_NE(refusalOf("clockstep:0@20+2").find("robot '0'"), std::string::npos);
  EXPECT_NE(refusalOf("clockstep:fusion/1@20+2").find("robot 'fusion/1'"), std::string::npos);
  EXPECT_NE(refusalOf("clockstep:1@20+0").find("at least 0.05 s"), std::string::npos);
  EXPECT_NE(refusalOf("clockstep:1@20+0.01").find("at least 0.05 s"), std::string::npos);
  EXPECT_NE(refusalOf("clockstep:1@20-11").find("at most 10"), std::string::npos);
  EXPECT_NE(refusalOf("clockstep:1@20+2s").find("step '2s'"), std::string::npos);
  EXPECT_NE(refusalOf("clockstep:1@20+-2").find("step '-2'"), std::string::npos);
  EXPECT_NE(refusalOf("clockstep:1@x+2").find("time 'x'"), std::string::npos);
  EXPECT_NE(refusalOf("clockstop:1@20+2").find("clockstep"), std::string::npos);
}

TEST(EvalFaults, RefusesWhatItCannotDoAndSaysWhy) {
  EXPECT_NE(refusalOf("restart:fusoin@20").find("no process 'fusoin'"), std::string::npos);
  EXPECT_NE(refusalOf("stall:2@20").find("needs its length"), std::string::npos);
  EXPECT_NE(refusalOf("stall:7@20+1").find("robot '7'"), std::string::npos);
  EXPECT_NE(refusalOf("restart:world_sim/1@3").find("belongs to no robot"), std::string::npos);
  EXPECT_NE(refusalOf("pause:fusion@3").find("unknown kind"), std::string::npos);
  EXPECT_NE(refusalOf("restart:fusion@-3").find("not a number of seconds"), std::string::npos);
  EXPECT_NE(refusalOf("restart:fusion@nan").find("not a number of seconds"), std::string::npos);
  EXPECT_NE(refusalOf("restart:fusion").find("expected KIND:TARGET@SECONDS"), std::string::npos);
  EXPECT_NE(refusalOf("stall:1@2+0").find("more than 0"), std::string::npos);
}

// 50 Hz samples of one robot from t0 to t1 with a status and an error.
void add(Summary& s, int robot, double t0, double t1, int status, double error) {
  const int n = static_cast<int>((t1 - t0) / 0.02 + 0.5);
  for (int i = 0; i < n; ++i) {
    Matched m;
    m.robot = robot;
    m.t = t0 + 0.02 * i;
    m.status = status;
    m.pos_error = error;
    s.matched.push_back(m);
  }
}

TEST(EvalFaults, ScoresRecoveryAndTheWorstTrackingError) {
  Summary s;
  // Robot 1: fusion restarted at 10 s: silent for 0.5 s, searching 1 s, then tracking 0.6 m off
  // for 0.1 s (a commit gone wrong) before it settles.
  add(s, 1, 0.0, 10.0, kTracking, 0.02);
  add(s, 1, 10.5, 11.5, kSearching, 3.0);
  add(s, 1, 11.5, 11.6, kTracking, 0.6);
  add(s, 1, 11.6, 20.0, kTracking, 0.03);
  // Robot 2 is not affected by robot 1's fault.
  add(s, 2, 0.0, 20.0, kTracking, 0.05);
  const std::vector<FaultEvent> events{{parseFault("restart:fusion/1@10"), 10.0, 10.0, 1}};
  const Robustness r = evaluateRobustness(s, events, {1, 2});
  ASSERT_EQ(r.faults.size(), 1u);
  const FaultResult& f = r.faults[0];
  EXPECT_EQ(f.recovery_s.size(), 1u);
  EXPECT_NEAR(f.recovery_max_s, 1.6, 0.03);  // the stretch within 0.2 m starts at 11.6 s
  EXPECT_DOUBLE_EQ(f.max_tracking_error_m, 0.6);
  EXPECT_EQ(f.tracking_over_limit, 5);
  EXPECT_DOUBLE_EQ(r.tracking_max_m, 0.6);
  EXPECT_EQ(r.worst_robot, 1);
  EXPECT_EQ(r.tracking_over_limit, 5);
  // Robot 1 was not tracking for 1.27 s of 20: searching 1 s, silent 0.52 s of which its last
  // TRACKING sample holds 0.25 s (max_gap_s); robot 2 never.
  EXPECT_NEAR(r.not_tracking_share_by_robot.at(1), 1.27 / 19.98, 0.002);
  EXPECT_NEAR(r.not_tracking_share_by_robot.at(2), 0.0, 1e-9);
  EXPECT_NEAR(r.not_tracking_share, 1.27 / 39.96, 0.002);
}

TEST(EvalFaults, AStallOfTheMachineAffectsEveryRobotAndANeverRecoveredOneSaysSo) {
  Summary s;
  add(s, 1, 0.0, 10.0, kTracking, 0.02);
  add(s, 1, 12.0, 20.0, kTracking, 0.02);  // back at once after the stall
  add(s, 2, 0.0, 10.0, kTracking, 0.02);
  add(s, 2, 12.0, 20.0, kSearching, 5.0);  // lost for good
  const std::vector<FaultEvent> events{{parseFault("stall:all@10+2"), 10.0, 12.0, 14}};
  const Robustness r = evaluateRobustness(s, events, {1, 2});
  const FaultResult& f = r.faults.at(0);
  EXPECT_NEAR(f.recovery_s.at(1), 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(f.recovery_s.at(2), -1.0);
  EXPECT_DOUBLE_EQ(f.recovery_max_s, -1.0);
  EXPECT_NE(robustnessJson(r).find("\"recovery_max_s\": -1.000"), std::string::npos);
  EXPECT_NE(robustnessLines(r).find("fault stall:all@10+2"), std::string::npos);
}

// A teammate's TEAM_STATE at t holding robot 1 (present or not) with a pose taken at pose_t.
TeamLinkSample link(int teammate, double t, bool present, double pose_t, int rejected) {
  TeamLinkSample l;
  l.robot = teammate;
  l.t = t;
  l.present[0] = present;
  l.pose_t[0] = pose_t;
  l.rejected[0] = rejected;
  return l;
}

TEST(EvalFaults, AClockStepIsScoredByRecoveryAndByTheTeammatesHearingTheRobotAgain) {
  Summary s;
  add(s, 1, 0.0, 10.0, kTracking, 0.02);
  add(s, 1, 10.4, 11.0, kSearching, 2.0);
  add(s, 1, 11.0, 20.0, kTracking, 0.05);
  add(s, 2, 0.0, 20.0, kTracking, 0.02);
  add(s, 3, 0.0, 20.0, kTracking, 0.02);
  std::vector<TeamLinkSample> team;
  for (int i = 0; i < 200; ++i) {
    const double t = 0.1 * i;
    // Robot 2 hears robot 1's restarted processes from 12 s on; until then it holds the last
    // pose from before the step (present for a while, then not) and refuses 3 packets.
    const bool back2 = t >= 12.0;
    team.push_back(
        link(2, t, t < 10.5 || back2, back2 ? t - 0.05 : std::min(t, 9.95), t < 10.0 ? 1 : 4));
    // Robot 3 never hears robot 1 again: it keeps a stale pose (as a wrong clock offset would).
    team.push_back(link(3, t, true, std::min(t, 9.95), t < 10.0 ? 0 : 30));
    // Robot 1's own TEAM_STATE is not a teammate's.
    team.push_back(link(1, t, true, t, 0));
  }
  const std::vector<FaultEvent> events{{parseFault("clockstep:1@10+2"), 10.0, 10.0, 7}};
  const Robustness r = evaluateRobustness(s, events, {1, 2, 3}, {}, team);
  const FaultResult& f = r.faults.at(0);
  EXPECT_EQ(f.recovery_s.size(), 1u);
  EXPECT_NEAR(f.recovery_max_s, 1.0, 0.03);
  EXPECT_DOUBLE_EQ(f.max_tracking_error_m, 0.05);
  ASSERT_EQ(f.heard_again_s.size(), 2u);
  EXPECT_NEAR(f.heard_again_s.at(2), 2.0, 1e-6);
  EXPECT_DOUBLE_EQ(f.heard_again_s.at(3), -1.0);
  EXPECT_EQ(f.packets_refused, 3 + 30);
  EXPECT_NE(robustnessLines(r).find("heard_again_s: 2=2.00 3=-1.00 packets_refused=33"),
            std::string::npos)
      << robustnessLines(r);
  EXPECT_NE(robustnessJson(r).find("\"step_s\": 2, \"packets_refused\": 33"), std::string::npos)
      << robustnessJson(r);
}

TEST(EvalFaults, TwinAmbiguousTrackingIsCountedAndAlsoReportedApart) {
  // After a restart with nothing to tell the field's halves apart, fusion commits by its prior
  // and says the pose may be its twin: 13 m off, TRACKING, twin-ambiguous.
  Summary s;
  add(s, 1, 0.0, 5.0, kTracking, 0.02);
  const std::size_t first_ambiguous = s.matched.size();
  add(s, 1, 5.0, 6.0, kTracking, 13.0);
  for (std::size_t i = first_ambiguous; i < s.matched.size(); ++i)
    s.matched[i].twin_ambiguous = true;
  const Robustness r = evaluateRobustness(s, {}, {1});
  EXPECT_DOUBLE_EQ(r.tracking_max_m, 13.0);
  EXPECT_EQ(r.tracking_over_limit, 50);
  EXPECT_DOUBLE_EQ(r.certain_max_m, 0.02);
  EXPECT_EQ(r.certain_over_limit, 0);
  EXPECT_EQ(r.twin_ambiguous_samples, 50u);
}

// BALL_STATE's rate falls when a loaded machine makes fusion's 30 Hz timer skip ticks; the
// median interval between its stamps stays the timer's period (the fusion team test's check).
TEST(EvalRates, BallStateIntervalStaysThePeriodWhenTicksAreSkipped) {
  std::vector<BallSample> balls;
  Utime t = 1'000'000;
  for (int i = 0; i < 90; ++i) {
    balls.push_back({.robot = 1, .utime = t});
    t += (i % 3 == 2) ? 66'666 : 33'333;  // every third tick lost: 22.5 Hz
    balls.push_back({.robot = 2, .utime = 1'000'000 + i * 100'000});  // a 10 Hz timer
  }
  const Summary s = evaluate({}, {StateSample{.robot = 1, .utime = 1'000'000}}, balls);
  EXPECT_NEAR(s.ball_state_hz.at(1), 22.5, 0.3);  // below the 24 Hz the test once asked for
  EXPECT_NEAR(s.ball_state_interval_p50_ms.at(1), 33.333, 1e-3);
  EXPECT_NEAR(s.ball_state_interval_p50_ms.at(2), 100.0, 1e-3);
  EXPECT_NEAR(s.ball_state_interval_max_ms.at(1), 66.666, 1e-3);
  EXPECT_NEAR(s.ball_state_interval_max_ms.at(2), 100.0, 1e-3);
  EXPECT_NE(summaryJson(s, "test").find("\"ball_state_interval_p50_ms\": {\"1\": 33.333"),
            std::string::npos);
}

}  // namespace
}  // namespace fieldline::eval
