// fieldline-tracking-png: runs the region tracker and its detectors on any frame (an image file,
// raw YUYV, or a simulated drive) and writes a PNG with the tracked regions tinted, their
// boundaries, the line points, the ball and the obstacles; optionally the line points as CSV
// (robot frame) and the detections as JSON (image coordinates). docs/tools.md.
//
//   fieldline-tracking-png --in frame.png --camera my_robot --csv points.csv --json frame.json
//   fieldline-tracking-png --in frame.yuyv --yuyv 320x240 --out tracked.png
//   fieldline-tracking-png --pose 1.0,0.5,0.3 --ball 2.0,1.2 --robot 3,-1 --out frame.png
#include "common/bus/cli.hpp"
#include "common/cli/cli.hpp"
#include "tools/tracking_png/tracking_png_app.hpp"

namespace cli = fieldline::cli;

int main(int argc, char** argv) {
  cli::App app{
      "Draws a frame (file or rendered) with the region tracker's regions, boundaries, line "
      "points, ball and obstacles; writes the line points as CSV and JSON."};
  fieldline::tracking_png::AppOptions options;
  options.addTo(app);
  FIELDLINE_PARSE(app, argc, argv);
  return fieldline::bus::runMain("tracking_png", [&]() -> int {
    fieldline::tracking_png::runApp(options);
    return 0;
  });
}
