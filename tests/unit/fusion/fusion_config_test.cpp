// The fusion settings file: the shipped preset loads and says what the code uses, absent keys
// keep the defaults, and a typo or a value out of range is an error naming file and line.
#include "services/fusion/fusion_config.hpp"

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace fieldline::fusion {
namespace fusion_config_test {

std::string readFile(const std::string& relative) {
  std::ifstream in(config::projectRoot() + "/" + relative);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string joined(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& line : lines)
    out += line + "\n";
  return out;
}

// What ships is what the code defaults to: the robots, the scenario tests and the unit tests
// run the same filter.
TEST(FusionConfig, TheShippedPresetEqualsTheDeclaredDefaults) {
  const FusionConfig shipped = loadFusionConfigPreset("default");
  const auto differences = fusionSettings().differences(shipped, FusionConfig{});
  EXPECT_TRUE(differences.empty()) << "config/fusion/default.yaml vs the code's default:\n"
                                   << joined(differences);
  // ... and says so with every key, its why, unit and range (regenerate with
  // `fieldline-fusion --print-config --config none > config/fusion/default.yaml`).
  EXPECT_EQ(readFile("config/fusion/default.yaml"), fusionConfigYaml(FusionConfig{}));
}

TEST(FusionConfig, EveryDeclaredSettingIsInTheDocsTable) {
  const std::string docs = readFile("docs/settings/fusion.md");
  const auto missing = fusionSettings().missingFrom(docs);
  EXPECT_TRUE(missing.empty()) << "not in docs/settings/fusion.md:\n" << joined(missing);
  // Regenerate with `fieldline-fusion --print-settings-table > docs/settings/fusion.md`.
  EXPECT_EQ(docs, fusionSettingsMarkdown());
  EXPECT_GE(fusionSettings().settings().size(), 127u);
}

std::string errorOf(const std::string& text) {
  try {
    loadFusionConfig(config::Node::loadString(text, "fusion.yaml"));
  } catch (const config::Error& e) {
    return e.what();
  }
  return "";
}

TEST(FusionConfig, ThePresetLoads) {
  const FusionConfig c = loadFusionConfigPreset("default");
  EXPECT_EQ(c.localizer.filter.window_us, 1'000'000);
  EXPECT_GT(c.localizer.filter.gate2, 0.0);
  EXPECT_GT(c.localizer.odometry.wheel_slip_density, 0.0);
  EXPECT_GT(c.localizer.filter.slip.inflation, 0.0);
  // Slips are bounded by the time they had (docs/fusion.md, "Eighth round").
  EXPECT_DOUBLE_EQ(c.localizer.filter.slip.max_speed, 4.0);
  EXPECT_DOUBLE_EQ(c.localizer.filter.slip.base_m, 0.15);
  EXPECT_EQ(c.matcher.method, MatchMethod::kRobustLeastSquares);
  EXPECT_DOUBLE_EQ(c.ball_rate_hz, 30.0);
  EXPECT_EQ(c.localizer.start_prior, StartPrior::kOwnHalf);
}

TEST(FusionConfig, AbsentKeysKeepTheDefaultsAndGivenOnesApply) {
  const FusionConfig c = loadFusionConfig(config::Node::loadString(
      "filter:\n  window_s: 0.5\ncalibration:\n  slip_inflation: 0\n  stamp_sigma_s: 0.004\n"
      "  correction_stamp_sigma_s: 0.003\n  gyro_heading_chi2: 6.5\n  heading_confirm_rad: 0.07\n"
      "localizer:\n  start_prior: none\nball:\n  max_age_s: 2.5\nmatcher:\n"
      "  method: force_field\n"));
  const FusionConfig defaults;
  EXPECT_EQ(c.localizer.filter.window_us, 500'000);
  EXPECT_DOUBLE_EQ(c.localizer.filter.slip.inflation, 0.0);
  EXPECT_DOUBLE_EQ(c.localizer.stamp_sigma_s, 0.004);
  EXPECT_DOUBLE_EQ(c.localizer.correction_stamp_sigma_s, 0.003);
  EXPECT_DOUBLE_EQ(c.localizer.filter.slip.gyro_heading_chi2, 6.5);
  EXPECT_DOUBLE_EQ(c.localizer.heading_confirm_rad, 0.07);
  EXPECT_EQ(c.localizer.start_prior, StartPrior::kNone);
  EXPECT_DOUBLE_EQ(c.ball.max_age_s, 2.5);
  EXPECT_EQ(c.matcher.method, MatchMethod::kForceField);
  EXPECT_DOUBLE_EQ(c.localizer.accept_cost_m, defaults.localizer.accept_cost_m);
  EXPECT_DOUBLE_EQ(c.localizer.filter.noise.linear_acceleration,
                   defaults.localizer.filter.noise.linear_acceleration);
}

TEST(FusionConfig, TwinByTeamKeysAndTheirContradiction) {
  const FusionConfig c = loadFusionConfig(config::Node::loadString(
      "twin_by_team:\n  votes: 5\n  agree_m: 0.4\n  min_centre_distance_m: 1.5\n"
      "  min_teammates: 3\n  max_ball_age_s: 0.3\n  max_picture_gap_s: 0.1\n"
      "  vote_gap_s: 1.5\n  max_sighting_sigma_m: 0.2\n  evidence_window_s: 3.0\n"));
  EXPECT_EQ(c.localizer.twin_vote_run, 5);
  EXPECT_DOUBLE_EQ(c.team_ball_vote.agree_m, 0.4);
  EXPECT_DOUBLE_EQ(c.team_ball_vote.min_centre_distance_m, 1.5);
  EXPECT_EQ(c.team_ball_vote.min_teammates, 3);
  EXPECT_EQ(c.team_ball_vote.max_ball_age_us, 300'000);
  EXPECT_EQ(c.team_ball_vote.max_picture_gap_us, 100'000);
  EXPECT_EQ(c.localizer.twin_vote_gap_us, 1'500'000);
  EXPECT_DOUBLE_EQ(c.team_ball_vote.max_sighting_sigma_m, 0.2);
  EXPECT_EQ(c.team_ball_vote.evidence_window_us, 3'000'000);
  // A gap of 0 would silently turn the votes off.
  EXPECT_NE(errorOf("twin_by_team:\n  vote_gap_s: 0\n").find("vote_gap_s"), std::string::npos);
  // One teammate's ball could agree with both our ball and its mirror image.
  const std::string e = errorOf("twin_by_team:\n  agree_m: 0.8\n  min_centre_distance_m: 0.6\n");
  EXPECT_NE(e.find("fusion.yaml"), std::string::npos) << e;
  EXPECT_NE(e.find("min_centre_distance_m"), std::string::npos) << e;
  EXPECT_NE(errorOf("twin_by_team:\n  vote: 3\n").find("vote"), std::string::npos);
}

TEST(FusionConfig, ContactAndBallRestartKeys) {
  const FusionConfig c = loadFusionConfig(config::Node::loadString(
      "contact:\n  distance_m: 0.35\n  hold_s: 0.25\n  heading_density: 0.7\n"
      "  search_steps: 2\n  search_always: true\n  search_min_points: 40\n"
      "ball:\n  restart_distance_m: 0.8\n  velocity_from_pair: true\n  pair_max_age_s: 0.1\n"
      "  settle_s: 0.25\n  smooth_pose: true\n  restart_speed_sigma: 3.5\n"
      "  fit_min_sightings: 4\n"));
  EXPECT_DOUBLE_EQ(c.localizer.filter.contact.distance_m, 0.35);
  EXPECT_EQ(c.localizer.filter.contact.hold_us, 250'000);
  EXPECT_DOUBLE_EQ(c.localizer.filter.contact.heading_density, 0.7);
  EXPECT_DOUBLE_EQ(c.localizer.filter.contact.position_density,
                   FusionConfig{}.localizer.filter.contact.position_density);
  EXPECT_EQ(c.localizer.contact_search_steps, 2);
  EXPECT_TRUE(c.localizer.twist_search_always);
  EXPECT_EQ(c.localizer.contact_search_min_points, 40u);
  EXPECT_DOUBLE_EQ(c.ball.restart_distance_m, 0.8);
  EXPECT_TRUE(c.ball.velocity_from_pair);
  EXPECT_DOUBLE_EQ(c.ball.pair_max_age_s, 0.1);
  EXPECT_DOUBLE_EQ(c.ball.settle_s, 0.25);
  EXPECT_TRUE(c.ball.smooth_pose);
  EXPECT_DOUBLE_EQ(c.ball.restart_speed_sigma, 3.5);
  EXPECT_EQ(c.ball.fit_min_sightings, 4);
  // The shipped file takes contact from the motor currents, not from the camera.
  const FusionConfig shipped = loadFusionConfigPreset("default");
  EXPECT_GT(shipped.localizer.current_contact.force_threshold_n, 0.0);
  EXPECT_EQ(shipped.localizer.current_contact.samples, 2);
  EXPECT_DOUBLE_EQ(shipped.localizer.filter.contact.distance_m, 0.0);
  const FusionConfig currents = loadFusionConfig(config::Node::loadString(
      "contact:\n  current_force_n: 12\n  current_samples: 3\n  current_max_a: 20\n"));
  EXPECT_DOUBLE_EQ(currents.localizer.current_contact.force_threshold_n, 12.0);
  EXPECT_EQ(currents.localizer.current_contact.samples, 3);
  EXPECT_DOUBLE_EQ(currents.localizer.current_contact.max_current_a, 20.0);
  EXPECT_NE(errorOf("contact:\n  current_samples: 0\n"), "");
  EXPECT_NE(errorOf("contact:\n  distance_m: -1\n"), "");
  EXPECT_NE(errorOf("contact:\n  serch_steps: 2\n"), "");
  // The push velocity's process (PushModel): on as shipped; decay times must be positive.
  EXPECT_GT(c.localizer.filter.push.density, 0.0);
  EXPECT_GT(shipped.localizer.filter.push.density, 0.0);
  EXPECT_GT(shipped.localizer.filter.push.max_speed, 0.0);
  const FusionConfig push = loadFusionConfig(config::Node::loadString(
      "contact:\n  push_density: 4\n  push_contact_decay_s: 0.8\n  push_free_decay_s: 0.05\n"
      "  push_max_speed: 3\n  push_unconfirmed_s: 0.2\n"));
  EXPECT_DOUBLE_EQ(push.localizer.filter.push.max_speed, 3.0);
  EXPECT_EQ(push.localizer.filter.push.unconfirmed_us, 200'000);
  EXPECT_DOUBLE_EQ(push.localizer.filter.push.density, 4.0);
  EXPECT_DOUBLE_EQ(push.localizer.filter.push.contact_decay_s, 0.8);
  EXPECT_DOUBLE_EQ(push.localizer.filter.push.free_decay_s, 0.05);
  EXPECT_NE(errorOf("contact:\n  push_free_decay_s: 0\n"), "");
  EXPECT_NE(errorOf("contact:\n  push_density: -1\n"), "");
}

TEST(FusionConfig, TyposAndBadValuesNameFileAndLine) {
  // An unknown key inside a section, on line 3.
  const std::string typo = errorOf("filter:\n  window_s: 1.0\n  gate_chi: 10\n");
  EXPECT_NE(typo.find("fusion.yaml:3"), std::string::npos) << typo;
  EXPECT_NE(typo.find("gate_chi"), std::string::npos) << typo;
  // An unknown section.
  EXPECT_NE(errorOf("calibrations:\n  x: 1\n").find("calibrations"), std::string::npos);
  // Out of range, on line 2.
  const std::string range = errorOf("odometry:\n  wheel_slip_density: -0.1\n");
  EXPECT_NE(range.find("fusion.yaml:2"), std::string::npos) << range;
  // Not a number.
  EXPECT_NE(errorOf("ball:\n  rate_hz: fast\n"), "");
  // A choice that is not one.
  EXPECT_NE(errorOf("localizer:\n  start_prior: left\n"), "");
  // Inconsistent thresholds.
  EXPECT_NE(errorOf("localizer:\n  accept_cost_m: 0.2\n  lost_cost_m: 0.1\n").find("lost_cost_m"),
            std::string::npos);
  // A feature hypothesis close enough to be fused cannot contradict the estimate.
  // The error names the key that was set, on its line.
  const std::string gate = errorOf("localizer:\n  feature_gate_m: 1.2\n");
  EXPECT_NE(gate.find("fusion.yaml:2: localizer.feature_gate_m: contradict_m must be at least"),
            std::string::npos)
      << gate;
  const std::string contradict =
      errorOf("localizer:\n  feature_gate_m: 0.5\n  contradict_m: 0.4\n");
  EXPECT_NE(contradict.find("fusion.yaml:3: localizer.contradict_m"), std::string::npos)
      << contradict;
  EXPECT_EQ(errorOf("localizer:\n  feature_gate_m: 1.2\n  contradict_m: 1.5\n"), "");
  // A Huber bound on the gyro's heading at or beyond the gate (every such frame gated first).
  const std::string huber =
      errorOf("filter:\n  gate_chi2: 9.0\ncalibration:\n  gyro_heading_chi2: 9.0\n");
  EXPECT_NE(huber.find("gyro_heading_chi2"), std::string::npos) << huber;
  EXPECT_NE(huber.find("fusion.yaml:4"), std::string::npos) << huber;
  EXPECT_EQ(errorOf("filter:\n  gate_chi2: 16.0\ncalibration:\n  gyro_heading_chi2: 9.0\n"), "");
  // The matcher's own checks.
  EXPECT_NE(errorOf("matcher:\n  outlier_distnce_m: 0.4\n"), "");
}

}  // namespace fusion_config_test
}  // namespace fieldline::fusion
