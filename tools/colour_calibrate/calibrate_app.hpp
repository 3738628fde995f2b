// The command line of fieldline-colour-calibrate (options, reading frames and painted masks,
// writing the table as boxes or as a full lookup table), kept out of main() so that main stays
// a few lines and the tests can reach each step.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/cli/cli.hpp"
#include "tools/colour_calibrate/colour_calibration.hpp"

namespace fieldline::calibration {

struct AppOptions {
  std::string camera_preset = "omni_sim", field_preset = "msl", out, base, yuyv_size, debug_png;
  std::string save_frame, painted;
  std::vector<std::string> inputs, poses, masks, settings;
  bool render = false, evaluate = false, shipped = false, lut = false, adapt = false;
  int frames = 9, drive = 0;
  double light_from = 0.7, light_to = 1.4, calibration_light = 0.0;
  std::vector<double> light_range{0.65, 1.55};

  void addTo(cli::App& app);
};

// Runs what the options ask (calibrate and write, or evaluate); returns the exit code. Throws on
// bad input (config::Error for configs).
int runApp(const AppOptions& options);

// The painting palette for user masks: paint over a frame (same size) in these colours (RGB,
// each channel within 6 levels), everything else is ignored, so the frame itself may be the
// canvas: ball (orange class) 255,128,0; obstacles (black class) 255,0,255; yellow goal
// 255,230,0; blue goal 20,90,230; neither carpet nor a class (team markers, people: kept out of
// the carpet samples, kUnknown) 0,255,255.
struct PaintColour {
  camera::ColourClass colour;
  int r, g, b;
};
const std::vector<PaintColour>& paintPalette();

// One mask per palette colour found in `painted` (a BGR image of the frame's size); classes with
// fewer than `min_pixels` painted pixels are left out. Throws std::invalid_argument for another
// size.
std::vector<UserMask> masksFromPainting(const cv::Mat& painted, const camera::FrameView& frame,
                                        int min_pixels = 10);

// The final table: the calibration's boxes, then the base table's other classes (its boxes, or
// for a lookup table its cells of classes not calibrated).
camera::ColourTable finalTable(const Calibration& calibration, const camera::ColourTable& base);

}  // namespace fieldline::calibration
