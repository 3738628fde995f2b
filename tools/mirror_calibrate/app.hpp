// fieldline-mirror-calibrate's options and run function (the main() only parses the command
// line). docs/mirror_calibration.md shows the commands.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "common/camera/mirror_model.hpp"
#include "common/cli/cli.hpp"
#include "tools/mirror_calibrate/mirror_calibration.hpp"
#include "tools/mirror_calibrate/pose_free.hpp"

namespace fieldline::calibration {

struct MirrorCalibrateOptions {
  // Input (one of): an image of the ring carpet, a rendered one (--render-rings), frames of the
  // field (--lines: a frame on its own; --spot: frames taken at one spot while the robot turned;
  // --pose optional, one per --lines frame), rendered ones (--render-lines), or a rendered venue
  // case (--venue).
  std::string rings;
  bool render_rings = false;
  std::vector<std::string> lines;
  std::vector<std::string> spots;
  std::vector<std::string> poses;
  bool render_lines = false;
  std::string venue;
  std::string field = "msl";
  // Ring distances: "1,1.5,2" (m) or a file with `distN = <mm>` lines.
  std::string distances;
  // Base camera preset: heading, mirrored, radii, reference height, colour table, pipeline; its
  // centre is the first guess (scaled when the frames have another size).
  std::string camera = "omni_sim";
  // Ring search range, px (0: from the image).
  double min_radius = 0.0;
  double max_radius = 0.0;
  double min_contrast = 18.0;
  int sectors = 8;
  double radius_step = 2.0;
  std::string offset = "auto";
  bool no_offset = false;
  // Rendered carpet or field frames: mirror centre moved by (du, dv) px, axis offset (x, y) m,
  // realism setting.
  std::string render_centre_shift = "0,0";
  std::string render_offset = "0,0";
  std::string realism = "clean";
  // Outputs.
  std::string out;
  std::string debug_png;
  bool verbose = false;

  void addTo(cli::App& app);
};

// Runs the calibration and prints the report; returns the exit code (0 written or nothing to
// write, kRefusedExit when the result would be useless: nothing is written). Throws on bad input.
int runMirrorCalibrate(const MirrorCalibrateOptions& options);

// Why a mirror read back from a written preset must not be used (empty: nothing): knots closer
// than half a pixel, distances not increasing or with a kink (a slope that falls to less than half
// of the previous one or grows more than fourfold), a table that ends before `min_reach` m, an
// axis offset beyond 0.25 m.
std::vector<std::string> mirrorProblems(const camera::MirrorParams& mirror, double min_reach);

// Per matched ring: the distance the finished table gives at the ring's points against the
// ring's true distance (the median relative error over all its points, and the worst sector's),
// and, for every ring but the outermost, the distance the curve through the other rings gives at
// its radius (how well the rings pin the distance function between them).
struct RingCheck {
  double distance = 0.0;
  int points = 0;
  double median_percent = 0.0;
  double worst_sector_percent = 0.0;
  double held_out_percent = std::numeric_limits<double>::quiet_NaN();
};
std::vector<RingCheck> checkRings(const RingCalibration& c, int sectors);

// The base camera for a ring image of another size: scaled, centred on the mirror's rim where it
// is seen (else the image's middle), searched from min_radius to max_radius when given (> 0).
camera::MirrorParams ringBaseFor(const GreyImage& image, camera::MirrorParams base,
                                 double min_radius, double max_radius);

// The colour_table value to write into a preset at `out_path` so that it names the same table as
// `colour_table` does for the loader (a preset name stays a name; a path becomes relative to the
// new file's folder).
std::string colourTableFor(const std::string& out_path, const std::string& colour_table);

}  // namespace fieldline::calibration
