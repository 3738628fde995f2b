// The fusion process without its command line: its options and the run that builds the line
// matcher and the node (services/fusion/main.cpp parses the options into FusionAppOptions).
#pragma once

#include <optional>
#include <string>

#include "common/bus/cli.hpp"
#include "common/cli/cli.hpp"

namespace fieldline::fusion {

struct FusionAppOptions {
  // Field preset (msl, fu2004) or a YAML path.
  std::string field = "msl";
  // Robot preset name or a YAML path.
  std::string robot = "fu2004";
  // Fusion settings: preset name (config/fusion/NAME.yaml) or a YAML path.
  std::string config = "default";
  // Directory of the distance grid cache; empty: no cache. addTo() sets
  // config::defaultCacheDirectory().
  std::string grid_cache;
  // The pose saved across restarts (pose_memory.hpp); empty: none. addTo() sets
  // /tmp/fieldline/fusion<N>.pose for robot N when not given.
  std::string state_file;
  // Start up without reading the saved pose.
  bool fresh = false;
  // Overrides of the settings file, set only when given on the command line.
  std::optional<std::string> matcher;      // lsq or force_field
  std::optional<std::string> start_prior;  // own_half or none
  std::optional<double> window_s;
  std::optional<double> ball_rate_hz;
  std::optional<double> ball_max_age_s;
  // Print the settings in effect as YAML (--print-config) or the settings' reference table as
  // Markdown (--print-settings-table) and exit.
  bool print_config = false;
  bool print_settings_table = false;

  // Adds --field, --robot-config, --config, --grid-cache, --state-file, --fresh, --matcher,
  // --start-prior, --window,
  // --ball-rate, --ball-max-age, --print-config and --print-settings-table to `app`.
  void addTo(cli::App& app);
};

// Reads the presets and, unless common.check_args (then returns 0 before the distance grid,
// seconds of CPU, is built), runs the node until stopped (SIGINT/SIGTERM). Throws config::Error
// for a bad preset. Returns the process's exit code.
int runFusion(const FusionAppOptions& options, const bus::CommonOptions& common);

}  // namespace fieldline::fusion
