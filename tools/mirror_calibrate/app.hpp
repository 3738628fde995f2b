// fieldline-mirror-calibrate's options and run function (the main() only parses the command
// line). docs/mirror_calibration.md shows the commands.
#pragma once

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace fieldline::calibration {

struct MirrorCalibrateOptions {
  // Input (one of): an image of the ring carpet, a rendered one (--render-rings), frames of the
  // field at known poses (--lines with one --pose each), or rendered ones (--render-lines).
  std::string rings;
  bool render_rings = false;
  std::vector<std::string> lines;
  std::vector<std::string> poses;
  bool render_lines = false;
  std::string field = "msl";
  // Ring distances: "1,1.5,2" (m) or a file with `distN = <mm>` lines.
  std::string distances;
  // Base camera preset: heading, mirrored, radii, reference height, colour table, pipeline; its
  // centre is the first guess.
  std::string camera = "omni_sim";
  // Ring search range, px (0: the base camera's self and outer radius).
  double min_radius = 0.0;
  double max_radius = 0.0;
  double min_contrast = 18.0;
  int sectors = 8;
  double radius_step = 2.0;
  bool no_offset = false;
  // Rendered carpet or field frames: mirror centre moved by (du, dv) px, axis offset (x, y) m,
  // realism setting.
  std::string render_centre_shift = "0,0";
  std::string render_offset = "0,0";
  std::string realism = "clean";
  // Outputs.
  std::string out;
  std::string debug_png;

  void addTo(CLI::App& app);
};

// Runs the calibration and prints the report; returns the exit code. Throws on bad input.
int runMirrorCalibrate(const MirrorCalibrateOptions& options);

}  // namespace fieldline::calibration
