// The command line of fieldline-tracking-png (options and what to do with them), kept out of
// main() so that main stays a few lines and the tests can run the tool's whole path.
#pragma once

#include <string>
#include <vector>

#include "common/cli/cli.hpp"

namespace fieldline::tracking_png {

struct AppOptions {
  std::string camera_preset = "omni_sim", colour_table, vision_config;
  // Input: a file (--in, with --yuyv WxH for raw frames) or a rendered drive (--pose ...).
  std::string in, yuyv_size;
  int repeat = 5;
  std::string field_preset = "msl", pose = "1.0,0.5,0.3", ball;
  std::vector<std::string> robots;
  int frames = 1;
  double speed = 1.0, omega_deg = 90.0;
  // Output.
  std::string out = "tracking_frame.png", csv, json;
  int scale = 3;
  bool touched = false;

  void addTo(cli::App& app);
};

// Tracks, writes the PNG (and the CSV and JSON when asked), prints a one-line summary. Throws on
// bad input (the caller reports it).
void runApp(const AppOptions& options);

}  // namespace fieldline::tracking_png
