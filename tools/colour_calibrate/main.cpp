// fieldline-colour-calibrate: learns the colour table from frames at a known pose on a known
// field (docs/calibration.md). The field model, projected through the mirror from the pose, says
// which pixels are carpet and which are line; green and white are fitted from those, the other
// classes kept from the camera's table (or fitted from masks painted over a frame).
//
//   fieldline-colour-calibrate --in frame.png --pose -5.2,1.3,0.4 --out colours.yaml
//   fieldline-colour-calibrate --render --pose 0.5,0.8,0.3 --realism washed --out c.yaml
//   fieldline-colour-calibrate --evaluate [--drive 500]          # the measurement in the docs
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/core.h>
#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>

#include "common/camera/image_io.hpp"
#include "common/config/config.hpp"
#include "tools/colour_calibrate/colour_calibration.hpp"
#include "tools/colour_calibrate/evaluation.hpp"

namespace camera = fieldline::camera;
namespace cal = fieldline::calibration;
namespace rt = fieldline::region_tracking;
using fieldline::geometry::Pose2;

namespace {

std::vector<double> numbers(const std::string& text, std::size_t count, const std::string& what) {
  std::vector<double> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      std::size_t used = 0;
      out.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw std::invalid_argument(what + ": '" + item + "' is not a number");
    }
  }
  if (out.size() != count) {
    throw std::invalid_argument(
        fmt::format("{}: expected {} comma-separated numbers, got '{}'", what, count, text));
  }
  return out;
}

Pose2 parsePose(const std::string& text) {
  const std::vector<double> p = numbers(text, 3, "--pose");
  return {p[0], p[1], p[2]};
}

void printCoverage(const cal::Coverage& c) {
  fmt::print(
      "coverage: carpet green {:5.1f} % (white {:4.1f} %) of {} px; lines within {} m white "
      "{:5.1f} % (green {:4.1f} %) of {} px; off the carpet green {:4.1f} % of {} px\n",
      100 * c.carpetGreen, 100 * c.carpetWhite, c.carpetPixels, cal::MaskParams{}.max_line_distance,
      100 * c.lineWhite, 100 * c.lineGreen, c.linePixels, 100 * c.offCarpetGreen,
      c.offCarpetPixels);
}

void printFits(const cal::Calibration& calibration) {
  for (const cal::ClassFit& f : calibration.fits) {
    fmt::print("{:7s} {:6d} samples:", camera::colourName(f.colour), f.samples);
    for (const camera::YuvBox& b : f.boxes) {
      fmt::print(" y[{},{}] u[{},{}] v[{},{}]", b.y[0], b.y[1], b.u[0], b.u[1], b.v[0], b.v[1]);
    }
    fmt::print("\n");
  }
}

// Input | predicted masks (green: carpet samples, white: line samples, dark: the un-eroded
// prediction) | classification with the new table.
cv::Mat debugImage(const camera::MirrorModel& mirror, const fieldline::field::FieldModel& field,
                   const cal::PosedFrame& f, const camera::ColourTable& table,
                   const cal::MaskParams& masks) {
  const std::vector<cal::PredictedPixel> predicted =
      cal::predictPixels(mirror, field, f.pose, masks);
  cv::Mat maskImage(mirror.height(), mirror.width(), CV_8UC3, cv::Scalar(0, 0, 0));
  for (int v = 0; v < mirror.height(); ++v) {
    for (int u = 0; u < mirror.width(); ++u) {
      const cal::PredictedPixel& p = predicted[static_cast<std::size_t>(v) * mirror.width() + u];
      cv::Vec3b c(0, 0, 0);
      if (p.truth == cal::Expected::kCarpet) c = {20, 60, 20};
      if (p.truth == cal::Expected::kLine) c = {90, 90, 90};
      if (p.truth == cal::Expected::kOffCarpet) c = {60, 40, 40};
      if (p.carpetCore) c = {40, 200, 40};
      if (p.lineCore) c = {255, 255, 255};
      maskImage.at<cv::Vec3b>(v, u) = c;
    }
  }
  cv::Mat out;
  cv::hconcat(std::vector<cv::Mat>{camera::toBgrImage(f.frame), maskImage,
                                   camera::classificationImage(f.frame, table)},
              out);
  return out;
}

int evaluate(const std::string& cameraPreset, const std::string& fieldPreset,
             const std::vector<std::string>& settingNames, const std::vector<std::string>& poses,
             int frames, int drive, double lightFrom, double lightTo, const cal::FitParams& params,
             bool shipped) {
  rt::SimCamera sim = rt::SimCamera::load(cameraPreset, fieldPreset);
  std::vector<cal::RealismSetting> settings;
  if (settingNames.empty()) {
    settings = cal::realismSettings();
  } else {
    for (const std::string& n : settingNames)
      settings.push_back(cal::realismSetting(n));
  }
  std::vector<Pose2> posesToUse;
  for (const std::string& p : poses)
    posesToUse.push_back(parsePose(p));
  if (posesToUse.empty()) posesToUse = {{0.5, 0.8, 0.3}, {-6.0, 1.5, 0.4}, {7.5, -4.5, 2.2}};
  fmt::print("{:11s} {:>18s} {:>9s} {:>9s} {:>7s} {:>7s} {:>7s} {:>7s} {:>7s}\n", "setting", "pose",
             "carpet_g", "line_w", "off_g", "points", "prec", "recall", "minrec");
  int failures = 0;
  for (const cal::RealismSetting& s : settings) {
    for (const Pose2& pose : posesToUse) {
      const cal::SettingResult r = cal::evaluateSetting(sim, s, pose, frames, params, shipped);
      const bool ok = r.score.precision() >= 0.9 && r.score.recall() >= 0.85;
      failures += ok ? 0 : 1;
      fmt::print(
          "{:11s} {:>18s} {:8.1f}% {:8.1f}% {:6.1f}% {:7.0f} {:6.1f}% {:6.1f}% {:6.1f}% {}\n",
          s.name, fmt::format("{:.1f},{:.1f},{:.1f}", pose.x, pose.y, pose.phi),
          100 * r.coverage.carpetGreen, 100 * r.coverage.lineWhite, 100 * r.coverage.offCarpetGreen,
          static_cast<double>(r.score.points) / std::max(1, r.score.frames),
          100 * r.score.precision(), 100 * r.score.recall(), 100 * r.score.minRecall,
          ok ? "" : "BELOW");
    }
  }
  if (drive > 0) {
    for (const cal::RealismSetting& s : settings) {
      // Calibrated at the drive's first pose in the drive's middle light (the geometric mean of
      // its first and last).
      const std::vector<Pose2> first =
          rt::motionPoses(sim.field, rt::Motion{.speed = 1.5, .omega = 0.5}, 1);
      cal::RealismSetting start = s;
      start.realism.light_factor = s.realism.light_factor * std::sqrt(lightFrom * lightTo);
      const cal::SettingResult calibrated =
          cal::evaluateSetting(sim, start, first[0], 3, params, shipped);
      const camera::ColourTable table(calibrated.calibration.boxes);
      const cal::DriveResult d = cal::evaluateDrive(sim, s, table, drive, lightFrom, lightTo);
      fmt::print(
          "drive {:11s} {} frames, light x{:.2f} -> x{:.2f}: {} line frames, precision {:.1f} % "
          "(min {:.1f} %), recall {:.1f} % (min {:.1f} %), frames meeting both {:.1f} %\n",
          s.name, drive, lightFrom, lightTo, d.score.frames, 100 * d.score.precision(),
          100 * d.score.minPrecision, 100 * d.score.recall(), 100 * d.score.minRecall,
          100.0 * d.score.framesMeeting / std::max(1, d.score.frames));
    }
  }
  fmt::print("{} setting/pose combinations below precision 90 % or recall 85 %\n", failures);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Colour calibration from frames at a known pose on a known field: fits green and white "
      "from the pixels the field model predicts, writes the colour YAML and prints the coverage"};
  std::string cameraPreset = "omni_sim", fieldPreset = "msl", out, base, yuyvSize, debugPng;
  std::string saveFrame;
  std::vector<std::string> inputs, poses, masks, settings;
  bool render = false, doEvaluate = false;
  int frames = 9, drive = 0;
  double lightFrom = 0.7, lightTo = 1.4;
  std::vector<double> lightRange{0.65, 1.55};
  bool shipped = false;
  app.add_option("--camera", cameraPreset, "camera preset (image size, mirror, colour table)")
      ->capture_default_str();
  app.add_option("--field", fieldPreset, "field preset")->capture_default_str();
  app.add_option("--in", inputs, "frame: PNG/JPEG/BMP, or raw YUYV with --yuyv (repeatable)");
  app.add_option("--yuyv", yuyvSize, "the inputs are raw YUYV 4:2:2 of this size, e.g. 320x240");
  app.add_option("--pose", poses,
                 "robot pose x,y,phi (m, m, rad, field frame) of each --in, or one for all");
  app.add_flag("--render", render, "calibrate from a frame the simulated camera renders at --pose");
  app.add_option("--realism", settings,
                 "realism setting for --render / --evaluate (clean, noise, washed, cast, blur, "
                 "vignetting, uneven, dim, bright, all; repeatable)");
  app.add_option("--mask", masks,
                 "CLASS=mask.png: pixels painted (nonzero) over the first frame are samples of "
                 "CLASS (orange, black, yellow, blue); repeatable");
  app.add_option("--base", base,
                 "colour table whose other classes are kept (default: the "
                 "camera's)");
  app.add_option("--out", out, "colour YAML to write");
  app.add_option("--debug-png", debugPng,
                 "write input | predicted masks | classes of the first frame");
  app.add_option("--save-frame", saveFrame, "write the (first) frame as PNG");
  app.add_flag("--evaluate", doEvaluate,
               "measure: per realism setting and pose, calibrate from one rendered frame, track, "
               "score the line points against the field model");
  app.add_option("--frames", frames, "frames tracked per setting and pose in --evaluate")
      ->check(CLI::Range(3, 1000))
      ->capture_default_str();
  app.add_option("--drive", drive, "also drive this many frames with the light changing")
      ->check(CLI::Range(0, 100000));
  app.add_option("--light-from", lightFrom, "light factor at the drive's start")
      ->capture_default_str();
  app.add_option("--light-to", lightTo, "light factor at the drive's end")->capture_default_str();
  app.add_option("--light-range", lightRange,
                 "the table holds for the calibration light times LOW..HIGH (1 1: only that light)")
      ->expected(2)
      ->capture_default_str();
  app.add_flag("--shipped", shipped,
               "--evaluate the camera's own colour table instead of calibrating (comparison)");
  CLI11_PARSE(app, argc, argv);
  cal::FitParams params;
  params.light_range = {lightRange[0], lightRange[1]};

  try {
    if (doEvaluate) {
      return evaluate(cameraPreset, fieldPreset, settings, poses, frames, drive, lightFrom, lightTo,
                      params, shipped);
    }
    rt::SimCamera sim = rt::SimCamera::load(cameraPreset, fieldPreset);
    if (!base.empty()) sim.table = camera::loadColourTablePreset(base);
    std::vector<std::vector<std::uint8_t>> raw;
    std::vector<cv::Mat> images;
    std::vector<cal::PosedFrame> posed;
    if (poses.empty()) throw std::invalid_argument("--pose is required");
    if (render) {
      if (!inputs.empty()) throw std::invalid_argument("--render and --in exclude each other");
      if (settings.size() > 1) throw std::invalid_argument("--render takes one --realism");
      if (!settings.empty()) {
        sim.renderer->realism().setParams(cal::realismSetting(settings[0]).realism);
      }
      for (const std::string& p : poses) {
        camera::SimScene scene;
        scene.robot = parsePose(p);
        sim.render(scene);
        raw.push_back(sim.frame);
        posed.push_back({{raw.back().data(), sim.renderer->width(), sim.renderer->height(),
                          sim.renderer->stride(), camera::PixelFormat::kYuyv},
                         scene.robot});
      }
    } else {
      if (inputs.empty()) throw std::invalid_argument("give --in frames or --render");
      if (poses.size() != 1 && poses.size() != inputs.size()) {
        throw std::invalid_argument("give one --pose, or one per --in");
      }
      raw.reserve(inputs.size());
      images.reserve(inputs.size());
      for (std::size_t i = 0; i < inputs.size(); ++i) {
        const Pose2 pose = parsePose(poses.size() == 1 ? poses[0] : poses[i]);
        if (!yuyvSize.empty()) {
          int w = 0, h = 0;
          char x = 0;
          if (std::sscanf(yuyvSize.c_str(), "%d%c%d", &w, &x, &h) != 3 || x != 'x' || w <= 0 ||
              h <= 0 || w % 2 != 0) {
            throw std::invalid_argument("--yuyv expects WIDTHxHEIGHT with an even width");
          }
          std::ifstream in(inputs[i], std::ios::binary);
          raw.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
          if (raw.back().size() != static_cast<std::size_t>(2 * w) * h) {
            throw std::runtime_error(fmt::format("{}: {} bytes, expected {} for {}x{} YUYV",
                                                 inputs[i], raw.back().size(), 2 * w * h, w, h));
          }
          posed.push_back({{raw.back().data(), w, h, 2 * w, camera::PixelFormat::kYuyv}, pose});
        } else {
          images.push_back(camera::readBgrImage(inputs[i]));
          posed.push_back({camera::viewOfBgr(images.back()), pose});
        }
      }
    }
    std::vector<cal::UserMask> userMasks;
    std::vector<cv::Mat> maskImages;
    for (const std::string& m : masks) {
      const std::size_t eq = m.find('=');
      const auto colour = camera::colourFromName(m.substr(0, eq == std::string::npos ? 0 : eq));
      if (eq == std::string::npos || !colour || *colour == camera::ColourClass::kUnknown) {
        throw std::invalid_argument("--mask expects CLASS=file.png, got " + m);
      }
      const cv::Mat painted = camera::readBgrImage(m.substr(eq + 1));
      if (painted.cols != posed[0].frame.width || painted.rows != posed[0].frame.height) {
        throw std::invalid_argument(m + ": the mask must have the frame's size");
      }
      cal::UserMask um{*colour, posed[0].frame, {}};
      um.mask.resize(static_cast<std::size_t>(painted.cols) * painted.rows);
      for (int v = 0; v < painted.rows; ++v) {
        for (int u = 0; u < painted.cols; ++u) {
          const cv::Vec3b c = painted.at<cv::Vec3b>(v, u);
          um.mask[static_cast<std::size_t>(v) * painted.cols + u] = (c[0] | c[1] | c[2]) != 0;
        }
      }
      userMasks.push_back(std::move(um));
    }

    const cal::Calibration calibration =
        cal::calibrate(sim.mirror, sim.field, posed, userMasks, sim.table.boxes(), params);
    const camera::ColourTable table(calibration.boxes);
    printFits(calibration);
    printCoverage(cal::measureCoverage(sim.mirror, sim.field, posed, table, params.masks));
    if (!out.empty()) {
      std::string comment = fmt::format(
          "Colour table from fieldline-colour-calibrate ({} frame(s), camera {}, field {}).\n"
          "White and green fitted from the field model's prediction; other classes kept.",
          posed.size(), cameraPreset, fieldPreset);
      std::ofstream file(out);
      file << cal::colourTableYaml(calibration.boxes, comment);
      if (!file) throw std::runtime_error("cannot write " + out);
      file.close();
      // Read back through the project's loader: what was written is a valid table.
      (void)camera::loadColourTablePreset(out);
      fmt::print("wrote {}\n", out);
    }
    if (!debugPng.empty()) {
      camera::writeImage(debugPng,
                         debugImage(sim.mirror, sim.field, posed[0], table, params.masks));
    }
    if (!saveFrame.empty()) camera::writeImage(saveFrame, camera::toBgrImage(posed[0].frame));
  } catch (const fieldline::config::Error& e) {
    fmt::print(stderr, "config error: {}\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    fmt::print(stderr, "fieldline-colour-calibrate: {}\n", e.what());
    return 1;
  }
  return 0;
}
