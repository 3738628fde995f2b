// The fusion node over memq:// with a simulated clock: odometry in at 50 Hz gives ROBOT_STATE
// with the odometry's utime for every message (and one more after each correcting frame), line
// frames bring it to TRACKING at the true pose, BALL_STATE goes out at 30 Hz with the ball in the
// field frame, bad input is counted in the status and changes nothing, and ODOMETRY_ONLY is
// reported when the lines stop.
#include "services/fusion/fusion_node.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "common/bus/node.hpp"
#include "common/msg/estimates.hpp"
#include "common/msg/field_features.hpp"
#include "common/msg/line_contours.hpp"
#include "common/msg/obstacle_observations.hpp"
#include "common/msg/team_state.hpp"
#include "common/time/clock.hpp"
#include "services/fusion/pose_memory.hpp"
#include "tests/unit/fusion/test_world.hpp"

namespace fieldline::fusion {
namespace fusion_node_test {

using test_support::TestWorld;
using test_support::world;

struct Rig {
  SimulatedClock clock{1'800'000'000'000'000};
  std::shared_ptr<bus::Connection> memq = bus::Connection::open("memq://");
  bus::Node sensors{{.process = "sensors", .robot_id = 3, .status_period_us = 0}, clock, memq};
  bus::Node fusion_bus{{.process = "fusion", .robot_id = 3, .status_period_us = 0}, clock, memq};
  bus::Node listener{{.process = "listener", .robot_id = 3, .status_period_us = 0}, clock, memq};
  FusionNode fusion;
  std::vector<robot_state_t> states;
  std::vector<ball_state_t> balls;
  geometry::Pose2 truth{-2.5, 1.0, 0.3};
  std::int32_t tick = 0;
  std::mt19937 rng{4};
  // Sent with every ODOMETRY when set (STATUS_CURRENTS).
  std::optional<std::array<float, 3>> currents;
  // Sent with every ODOMETRY when set (STATUS_GYRO): the gyro's rotation over the period.
  std::optional<double> gyro_dphi;

  static FusionNodeOptions options() {
    FusionNodeOptions o;
    o.robot = world().robot;
    return o;
  }

  explicit Rig(FusionNodeOptions o = options()) : fusion(fusion_bus, o, world().functions()) {
    listener.subscribe(bus::channels::kRobotState,
                       [this](const robot_state_t& m) { states.push_back(m); });
    listener.subscribe(bus::channels::kBallState,
                       [this](const ball_state_t& m) { balls.push_back(m); });
  }

  void spin() {
    for (int k = 0; k < 4; ++k) {
      fusion_bus.spinOnce(0);
      listener.spinOnce(0);
    }
  }

  // One 20 ms period standing still: odometry (8 ms old), a line frame (80 ms old) every fifth
  // period, a ball sighting every period when `ball` is set.
  void period(int i, bool lines, bool ball) {
    clock.advance(20'000);
    odometry_t o{};
    o.header.utime = clock.now() - 8'000;
    // A controller clock that disagrees with the header by a few ms from sample to sample: the
    // header (the bridge's stamp) is the physical time fusion uses, the controller's is not
    // mapped again.
    o.controller_utime = 1'000'000 + 20'000 * i + (i % 3) * 3'000;
    o.wheel_count = 3;
    o.ticks = {tick, tick, tick};
    o.wheel_current = {0.0f, 0.0f, 0.0f};
    if (currents) {
      o.status |= odometry_t::STATUS_CURRENTS;
      for (std::size_t k = 0; k < 3; ++k)
        o.wheel_current[k] = (*currents)[k];
    }
    if (gyro_dphi) {
      o.status |= odometry_t::STATUS_GYRO;
      o.gyro_dphi = *gyro_dphi;
    }
    sensors.publish(bus::channels::kOdometry, o);
    if (lines && i % 5 == 0) {
      line_contours_t m{};
      m.header.utime = clock.now() - 80'000;
      perception::LinePoints points;
      points.points = world().view(truth, rng);
      points.sequences.push_back({0, static_cast<int>(points.points.size())});
      msg::toMessage(points, m);
      sensors.publish(bus::channels::kVisionLines, m);
    }
    if (ball) {
      perception::BallSighting s;
      s.utime = clock.now() - 60'000;
      s.visible = true;
      const geometry::Vec2 local = geometry::pointFieldToRobot(truth, {-1.0, 2.0});
      s.x = local.x();
      s.y = local.y();
      s.sigma_radial = 0.05;
      s.sigma_tangential = 0.03;
      ball_observation_t b{};
      msg::toMessage(s, b);
      sensors.publish(bus::channels::kVisionBall, b);
    }
    spin();
  }
};

TEST(FusionNode, PublishesStateForEveryOdometryAndCorrectingFrameAndBallAt30HzAndFindsItself) {
  Rig rig;
  for (int i = 0; i < 100; ++i)
    rig.period(i, true, true);
  // Every odometry message gave one ROBOT_STATE with its utime, and every line frame that moved
  // the estimate one more at once, stamped with the newest odometry's utime (the same stamp,
  // corrected): a frame 80 ms old, the odometry 8 ms old, so 72 ms since its correction.
  std::size_t odometry_states = 1;
  std::size_t frame_states = 0;
  for (std::size_t i = 1; i < rig.states.size(); ++i) {
    const robot_state_t& previous = rig.states[i - 1];
    const robot_state_t& state = rig.states[i];
    if (state.header.utime == previous.header.utime) {
      ++frame_states;
      EXPECT_TRUE(state.since_vision_us != previous.since_vision_us || state.x != previous.x ||
                  state.y != previous.y || state.phi != previous.phi ||
                  state.status != previous.status)
          << "state " << i << " repeats the previous one unchanged";
      if (state.status == robot_state_t::STATUS_TRACKING) {
        EXPECT_EQ(state.since_vision_us, 72'000) << "state " << i;
      }
    } else {
      ++odometry_states;
      EXPECT_EQ(state.header.utime - previous.header.utime, 20'000) << "state " << i;
    }
  }
  EXPECT_EQ(odometry_states, 100u);
  // 20 frames; the first ones only search (they move the hypotheses, not the estimate).
  EXPECT_GE(frame_states, 10u);
  EXPECT_LE(frame_states, 20u);
  const robot_state_t& last = rig.states.back();
  EXPECT_EQ(last.status, robot_state_t::STATUS_TRACKING);
  EXPECT_LT(std::hypot(last.x - rig.truth.x, last.y - rig.truth.y), 0.05);
  EXPECT_LT(std::abs(geometry::angleDiff(last.phi, rig.truth.phi)), 0.03);
  // 2 s at 30 Hz.
  EXPECT_NEAR(static_cast<double>(rig.balls.size()), 60.0, 1.0);
  const ball_state_t& ball = rig.balls.back();
  EXPECT_TRUE(ball.valid);
  EXPECT_NEAR(ball.x, -1.0, 0.1);
  EXPECT_NEAR(ball.y, 2.0, 0.1);
}

TEST(FusionNode, BadInputIsCountedAndOdometryOnlyWhenLinesStop) {
  Rig rig;
  for (int i = 0; i < 60; ++i)
    rig.period(i, true, false);
  ASSERT_EQ(rig.states.back().status, robot_state_t::STATUS_TRACKING);
  const robot_state_t before = rig.states.back();

  // A line frame from the future and one from long ago: refused and counted.
  line_contours_t m{};
  perception::LinePoints points;
  points.points = world().view(rig.truth, rig.rng);
  msg::toMessage(points, m);
  m.header.utime = rig.clock.now() - 3'000'000;
  rig.sensors.publish(bus::channels::kVisionLines, m);
  // An odometry jump no wheel can make.
  odometry_t jump{};
  jump.header.utime = rig.clock.now() - 4'000;
  jump.wheel_count = 3;
  jump.ticks = {500'000, 0, 0};
  jump.wheel_current = {0.0f, 0.0f, 0.0f};
  rig.sensors.publish(bus::channels::kOdometry, jump);
  rig.spin();
  EXPECT_GE(rig.fusion_bus.status().errorCount("lines_too_old"), 1);
  EXPECT_GE(rig.fusion_bus.status().errorCount("odometry_jump"), 1);
  const robot_state_t after = rig.states.back();
  EXPECT_NEAR(after.x, before.x, 0.01);
  EXPECT_NEAR(after.y, before.y, 0.01);
  EXPECT_EQ(after.status, robot_state_t::STATUS_TRACKING);

  // The camera goes silent: odometry only after a second.
  for (int i = 0; i < 70; ++i)
    rig.period(i, false, false);
  EXPECT_EQ(rig.states.back().status, robot_state_t::STATUS_ODOMETRY_ONLY);
  // No ball ever seen: BALL_STATE says so.
  ASSERT_FALSE(rig.balls.empty());
  EXPECT_FALSE(rig.balls.back().valid);
}

// Every kind of bad input the issue names, after the robot tracks: refused, counted in
// SERVICE_STATUS, the estimate unchanged, the process alive. NaN never crosses the bus (the
// publishing node validates its output and counts invalid_output; the library tests feed NaN to
// the algorithms directly); what does cross is refused by fusion and counted there.
TEST(FusionNode, EveryKindOfBadInputIsCountedAndChangesNothing) {
  Rig rig;
  for (int i = 0; i < 60; ++i)
    rig.period(i, true, true);
  ASSERT_EQ(rig.states.back().status, robot_state_t::STATUS_TRACKING);
  const robot_state_t before = rig.states.back();
  const auto& status = rig.fusion_bus.status();

  // Line points with NaN: refused by the sender's bus validation, never delivered.
  perception::LinePoints points;
  points.points = world().view(rig.truth, rig.rng);
  points.sequences.push_back({0, static_cast<int>(points.points.size())});
  line_contours_t lines{};
  msg::toMessage(points, lines);
  line_contours_t nan_lines = lines;
  nan_lines.header.utime = rig.clock.now() - 80'000;
  nan_lines.x[0] = std::nanf("");
  EXPECT_FALSE(rig.sensors.publish(bus::channels::kVisionLines, nan_lines));
  EXPECT_GE(rig.sensors.status().errorCount("invalid_output"), 1);
  // A frame from the future (refused by the receiving bus), one older than the window (by
  // fusion's filter).
  line_contours_t future = lines;
  future.header.utime = rig.clock.now() + 2'000'000;
  rig.sensors.publish(bus::channels::kVisionLines, future);
  rig.spin();
  EXPECT_EQ(status.errorCount("future_utime"), 1);
  line_contours_t old = lines;
  old.header.utime = rig.clock.now() - 1'500'000;
  rig.sensors.publish(bus::channels::kVisionLines, old);
  rig.spin();
  EXPECT_GE(status.errorCount("lines_too_old"), 1);

  // A feature hypothesis with an absurd (negative) sigma, and one far in the future.
  perception::FieldFeatures features;
  perception::FieldFeature feature;
  feature.kind = perception::FeatureKind::kCentreCircle;
  feature.quality = 0.9;
  features.features.push_back(feature);
  perception::PoseHypothesis h;
  h.feature = 0;
  h.pose = rig.truth;
  h.pose.x += 0.3;
  h.sigma_xy = -0.1;
  h.sigma_phi = 0.05;
  features.hypotheses.push_back(h);
  field_features_t fm{};
  msg::toMessage(features, fm);
  fm.header.utime = rig.clock.now() - 60'000;
  if (rig.sensors.publish(bus::channels::kFieldFeatures, fm)) {
    rig.spin();
    EXPECT_GE(status.errorCount("features_not_finite"), 1);
  } else {
    EXPECT_GE(rig.sensors.status().errorCount("invalid_output"), 2);
  }

  // The same odometry sample twice, and a jump no wheel can make.
  odometry_t o{};
  o.header.utime = rig.clock.now() - 8'000;
  o.wheel_count = 3;
  o.ticks = {rig.tick, rig.tick, rig.tick};
  o.wheel_current = {0.0f, 0.0f, 0.0f};
  rig.sensors.publish(bus::channels::kOdometry, o);
  rig.spin();
  EXPECT_GE(status.errorCount("odometry_duplicate"), 1);
  odometry_t jump = o;
  jump.header.utime = rig.clock.now() - 4'000;
  jump.ticks[1] = 400'000;
  rig.sensors.publish(bus::channels::kOdometry, jump);
  rig.spin();
  EXPECT_GE(status.errorCount("odometry_jump"), 1);
  // Ticks of four wheels for this three-wheeled robot: refused and counted, nothing moves.
  odometry_t four = o;
  four.header.utime = rig.clock.now() - 2'000;
  four.wheel_count = 4;
  four.ticks = {rig.tick, rig.tick, rig.tick, rig.tick};
  four.wheel_current = {0.0f, 0.0f, 0.0f, 0.0f};
  rig.sensors.publish(bus::channels::kOdometry, four);
  rig.spin();
  EXPECT_GE(status.errorCount("odometry_wheel_count"), 1);

  // Nothing moved the estimate, and the node still runs and tracks.
  for (int i = 0; i < 5; ++i)
    rig.period(i + 1, false, false);
  const robot_state_t after = rig.states.back();
  EXPECT_NEAR(after.x, before.x, 0.02);
  EXPECT_NEAR(after.y, before.y, 0.02);
  EXPECT_NEAR(geometry::angleDiff(after.phi, before.phi), 0.0, 0.02);
  EXPECT_EQ(after.status, robot_state_t::STATUS_TRACKING);
  EXPECT_TRUE(rig.balls.back().valid);
}

// VISION_OBSTACLES reaches the localizer: an obstacle at the body is contact evidence, one far
// away is not, and a frame with a negative distance is refused and counted in SERVICE_STATUS.
TEST(FusionNode, ObstaclesAtTheBodyAreContactEvidence) {
  FusionNodeOptions o = Rig::options();
  o.localizer.filter.contact.distance_m = 0.4;
  Rig rig(o);
  for (int i = 0; i < 60; ++i)
    rig.period(i, true, false);
  ASSERT_EQ(rig.states.back().status, robot_state_t::STATUS_TRACKING);
  const auto send = [&](double distance, Utime age) {
    perception::ObstacleSightings s;
    s.utime = rig.clock.now() - age;
    s.obstacles.push_back({0.5, distance, 0.6, 0.5, distance * 0.88, distance * 0.48});
    obstacle_observations_t m{};
    msg::toMessage(s, m);
    rig.sensors.publish(bus::channels::kVisionObstacles, m);
    rig.spin();
  };
  send(2.0, 70'000);
  EXPECT_EQ(rig.fusion.localizer().counters().contact_frames, 0u);
  send(0.29, 60'000);
  EXPECT_EQ(rig.fusion.localizer().counters().contact_frames, 1u);
  EXPECT_TRUE(rig.fusion.localizer().inContact(rig.clock.now() - 30'000));
  send(-0.5, 50'000);
  EXPECT_EQ(rig.fusion_bus.status().errorCount("obstacles_not_finite"), 1);
  EXPECT_EQ(rig.fusion.localizer().counters().contact_frames, 1u);
}

TEST(FusionNode, WheelCurrentsAtTheFrictionLimitAreContactEvidence) {
  FusionNodeOptions o = Rig::options();
  o.localizer.current_contact.force_threshold_n = 8.0;
  Rig rig(o);
  rig.currents = std::array<float, 3>{0.0f, 0.0f, 0.0f};
  for (int i = 0; i < 60; ++i)
    rig.period(i, true, false);
  ASSERT_EQ(rig.states.back().status, robot_state_t::STATUS_TRACKING);
  EXPECT_EQ(rig.fusion.localizer().counters().current_contacts, 0u);
  EXPECT_FALSE(rig.fusion.localizer().inContact(rig.clock.now() - 8'000));
  // Standing still while the wheels push at the friction limit (13 N, 1.7 A): pushed.
  rig.currents = std::array<float, 3>{1.7f, -1.7f, 0.0f};
  for (int i = 60; i < 66; ++i)
    rig.period(i, false, false);
  EXPECT_GE(rig.fusion.localizer().counters().current_contacts, 2u);
  EXPECT_TRUE(rig.fusion.localizer().inContact(rig.clock.now() - 60'000));
  // A NaN current is counted in SERVICE_STATUS; the sample's ticks still give a ROBOT_STATE.
  const std::size_t states = rig.states.size();
  rig.currents = std::array<float, 3>{std::nanf(""), 0.0f, 0.0f};
  rig.period(66, false, false);
  EXPECT_EQ(rig.fusion_bus.status().errorCount("current_not_finite"), 1);
  rig.currents = std::array<float, 3>{0.0f, 900.0f, 0.0f};
  rig.period(67, false, false);
  EXPECT_EQ(rig.fusion_bus.status().errorCount("current_absurd"), 1);
  EXPECT_EQ(rig.states.size(), states + 2);
}

TEST(FusionNode, TheGyroTurnsTheEstimateAndBadGyroValuesAreCounted) {
  Rig rig;
  rig.gyro_dphi = 0.0;
  for (int i = 0; i < 60; ++i)
    rig.period(i, true, false);
  ASSERT_EQ(rig.states.back().status, robot_state_t::STATUS_TRACKING);
  EXPECT_GT(rig.fusion.localizer().counters().gyro_steps, 50u);
  const double phi0 = rig.states.back().phi;
  // Twisted at 1 rad/s for 0.2 s without line frames while the wheels stand still: the gyro
  // turns the estimate by 0.2 rad.
  rig.gyro_dphi = 0.02;
  for (int i = 60; i < 70; ++i)
    rig.period(i, false, false);
  EXPECT_NEAR(geometry::angleDiff(rig.states.back().phi, phi0), 0.2, 0.01);
  // NaN and absurd gyro values: errors in SERVICE_STATUS, the wheels' heading used, a
  // ROBOT_STATE for each sample all the same.
  const std::size_t states = rig.states.size();
  const double phi1 = rig.states.back().phi;
  rig.gyro_dphi = std::nan("");
  rig.period(70, false, false);
  rig.gyro_dphi = 3.0;  // 150 rad/s, beyond the gyro's range
  rig.period(71, false, false);
  EXPECT_EQ(rig.fusion_bus.status().errorCount("gyro_not_finite"), 1);
  EXPECT_EQ(rig.fusion_bus.status().errorCount("gyro_absurd"), 1);
  EXPECT_EQ(rig.states.size(), states + 2);
  EXPECT_NEAR(geometry::angleDiff(rig.states.back().phi, phi1), 0.0, 0.01);
}

// TEAM_STATE: two teammates see the ball where this robot sees it, so the start-up commit (only
// the own-half prior told the twins apart) is confirmed; without teammates it stays ambiguous.
TEST(FusionNode, TeammatesBallsConfirmTheStartUpHalf) {
  for (const bool with_team : {false, true}) {
    Rig rig;
    for (int i = 0; i < 80; ++i) {
      if (with_team && i % 5 == 0) {
        perception::TeamState team;
        team.utime = rig.clock.now();
        for (const std::size_t k : {0u, 4u}) {  // robots 1 and 5; this one is robot 3
          perception::TeammateState& r = team.robots[k];
          r.present = r.ball_valid = true;
          r.ball_x = -1.0;
          r.ball_y = 2.0;
          r.ball_age_us = 50'000;
        }
        team_state_t m{};
        msg::toMessage(team, m);
        rig.sensors.publish(bus::channels::kTeamState, m);
      }
      rig.period(i, true, true);
    }
    ASSERT_EQ(rig.states.back().status, robot_state_t::STATUS_TRACKING);
    const Localizer& l = rig.fusion.localizer();
    EXPECT_EQ(l.ambiguous(), !with_team);
    // ROBOT_STATE says so.
    EXPECT_EQ(rig.states.back().twin_ambiguous != 0, !with_team);
    EXPECT_EQ(l.counters().twin_confirmed_by_team, with_team ? 1u : 0u);
    EXPECT_EQ(l.counters().twin_flips_by_team, 0u);
  }
}

// Once the half is confirmed, teammates that flag their own poses as possibly the twin and see the
// ball mirrored cannot doubt it; teammates sure of their poses can.
TEST(FusionNode, OnlyTeammatesSureOfTheirPosesDoubtACertainHalf) {
  Rig rig;
  const auto publishTeam = [&rig](double ball_x, double ball_y, bool flagged) {
    perception::TeamState team;
    team.utime = rig.clock.now();
    for (const std::size_t k : {0u, 4u}) {  // robots 1 and 5; this one is robot 3
      perception::TeammateState& r = team.robots[k];
      r.present = r.ball_valid = true;
      r.twin_ambiguous = flagged;
      r.ball_x = ball_x;
      r.ball_y = ball_y;
      r.ball_age_us = 50'000;
    }
    team_state_t m{};
    msg::toMessage(team, m);
    rig.sensors.publish(bus::channels::kTeamState, m);
  };
  int i = 0;
  for (; i < 80; ++i) {
    if (i % 5 == 0) publishTeam(-1.0, 2.0, false);
    rig.period(i, true, true);
  }
  const Localizer& l = rig.fusion.localizer();
  ASSERT_FALSE(l.ambiguous());
  for (; i < 200; ++i) {
    if (i % 5 == 0) publishTeam(1.0, -2.0, true);
    rig.period(i, true, true);
  }
  EXPECT_FALSE(l.ambiguous());
  EXPECT_EQ(l.counters().twin_doubted_by_team, 0u);
  for (; i < 320; ++i) {
    if (i % 5 == 0) publishTeam(1.0, -2.0, false);
    rig.period(i, true, true);
  }
  EXPECT_GE(l.counters().twin_doubted_by_team, 1u);
}

// A fusion restarted in the opponent's half (docs/faults.md: the clock-step fault put robot 2 on
// its twin, 8 m off and TRACKING): started afresh it commits to the twin by the own-half prior;
// finding the pose it saved 0.8 s ago under the same supervisor, it resumes on the right half,
// certain and TRACKING, and says so; a stale or corrupt file is refused (counted) and the start
// is a start-up. The resumed node saves its own pose again while tracking and when it stops.
TEST(FusionNode, ARestartInTheOpponentsHalfResumesFromTheSavedPose) {
  const std::string path =
      testing::TempDir() + "fusion_node_resume_" + std::to_string(::getpid()) + ".pose";
  Utime steady = 9'000'000'000;
  const geometry::Pose2 truth{3.0, 1.5, 2.5};
  SavedPose saved;
  saved.robot_id = 3;
  saved.field = "msl";
  saved.supervisor = "boot b pid 7 started 8";
  saved.saved_steady_us = steady - 800'000;
  saved.pose = {2.9, 1.6, 2.45};
  saved.covariance = Eigen::Vector3d(0.01, 0.01, 0.003).asDiagonal();
  enum class File { kNone, kRecent, kStale, kCorrupt };
  for (const File file : {File::kNone, File::kRecent, File::kStale, File::kCorrupt}) {
    SCOPED_TRACE(static_cast<int>(file));
    steady = 9'000'000'000;
    std::remove(path.c_str());
    if (file == File::kRecent) writeSavedPoseFile(path, saved);
    if (file == File::kStale) {
      SavedPose old = saved;
      old.saved_steady_us = steady - 6'000'000;
      writeSavedPoseFile(path, old);
    }
    if (file == File::kCorrupt) std::ofstream(path) << "fieldline-fusion-pose 1\nrobot 3\n";
    FusionNodeOptions o = Rig::options();
    o.pose_memory = {path, false, "msl", saved.supervisor, 5.0, [&steady] { return steady; }};
    {
      Rig rig(o);
      rig.truth = truth;
      // A refused file gives a start-up: the case without a file shows where it goes.
      const bool refused = file == File::kStale || file == File::kCorrupt;
      for (int i = 0; i < (refused ? 5 : 80); ++i) {
        steady += 20'000;
        rig.period(i, true, false);
      }
      const Localizer& l = rig.fusion.localizer();
      const robot_state_t& last = rig.states.back();
      EXPECT_EQ(rig.fusion_bus.status().errorCount("resume_corrupt"),
                file == File::kCorrupt ? 1 : 0);
      if (refused) {
        EXPECT_FALSE(l.restarted());
        EXPECT_EQ(l.counters().resumed, 0u);
        continue;
      }
      ASSERT_EQ(last.status, robot_state_t::STATUS_TRACKING);
      if (file != File::kRecent) {
        // A start-up: the own-half prior, on the twin, ambiguous.
        EXPECT_LT(std::hypot(last.x + truth.x, last.y + truth.y), 0.15);
        EXPECT_TRUE(l.ambiguous());
        EXPECT_EQ(l.counters().resumed, 0u);
        continue;
      }
      EXPECT_LT(std::hypot(last.x - truth.x, last.y - truth.y), 0.15);
      EXPECT_FALSE(l.ambiguous());
      EXPECT_EQ(last.twin_ambiguous, 0);
      EXPECT_EQ(l.counters().resumed, 1u);
      // Saved again while tracking: this run's pose, now.
      const auto again = readSavedPoseFile(path);
      ASSERT_TRUE(again.has_value());
      EXPECT_GT(again->saved_steady_us, saved.saved_steady_us + 1'000'000);
      EXPECT_LT(std::hypot(again->pose.x - truth.x, again->pose.y - truth.y), 0.15);
      steady += 1'000'000;
    }
    if (file == File::kRecent) {
      // The stop saved the pose of the moment.
      const auto stopped = readSavedPoseFile(path);
      ASSERT_TRUE(stopped.has_value());
      EXPECT_EQ(stopped->saved_steady_us, steady);
    }
  }
  std::remove(path.c_str());
}

}  // namespace fusion_node_test
}  // namespace fieldline::fusion
