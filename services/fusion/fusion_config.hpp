// The fusion process's settings in one YAML file (config/fusion/default.yaml): the filter's
// window and gate, the process and odometry noise, the localizer's thresholds, the covariance
// calibration (floors, slip and collision inflation, the uncertainty of a committed pose), contact
// evidence, the ball filter, the team's twin votes and layer 2's matcher. Each is declared once in
// fusionSettings() (fusion_config.cpp), whose defaults are the structs' initializers and are what
// ships. Every key is optional; an unknown key or a value out of range is an error with file:line.
#pragma once

#include <string>

#include "common/config/config.hpp"
#include "common/config/settings.hpp"
#include "services/fusion/ball_filter.hpp"
#include "services/fusion/line_matcher.hpp"
#include "services/fusion/localizer.hpp"
#include "services/fusion/team_twin.hpp"

namespace fieldline::fusion {

struct FusionConfig {
  LocalizerParams localizer;
  BallFilterParams ball;
  MatcherParams matcher;
  TeamBallVoteParams team_ball_vote;
  // BALL_STATE messages per second.
  double ball_rate_hz = 30.0;
};

// Every fusion setting: loader, --print-config, docs table (docs/settings/fusion.md).
const config::SettingsTable<FusionConfig>& fusionSettings();
// The `matcher` section's settings (included in fusionSettings()).
const config::SettingsTable<MatcherParams>& matcherSettings();

// `c` as a fusion settings file, every key with its why, unit and range (`--print-config`;
// config/fusion/default.yaml is this text for the defaults).
std::string fusionConfigYaml(const FusionConfig& c);
// docs/settings/fusion.md: every setting's key, default, unit, range and why.
std::string fusionSettingsMarkdown();

// Reads the root of a fusion config file: sections filter, process_noise, odometry, localizer,
// calibration, contact, ball, twin_by_team, matcher (each optional).
FusionConfig loadFusionConfig(const config::Node& root);
// Preset name (config/fusion/NAME.yaml) or path; "none": the code's defaults.
FusionConfig loadFusionConfigPreset(const std::string& name_or_path);

}  // namespace fieldline::fusion
