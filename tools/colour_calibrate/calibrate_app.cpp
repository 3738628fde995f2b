#include "tools/colour_calibrate/calibrate_app.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <fmt/core.h>

#include <opencv2/imgproc.hpp>

#include "common/camera/image_io.hpp"
#include "common/config/config.hpp"
#include "services/camera/camera_config.hpp"
#include "tools/calibration_common/staged_output.hpp"
#include "tools/colour_calibrate/evaluation.hpp"
#include "tools/colour_calibrate/image_calibration.hpp"

namespace fieldline::calibration {

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
      100 * c.carpet_green, 100 * c.carpet_white, c.carpet_pixels,
      cal::MaskParams{}.max_line_distance, 100 * c.line_white, 100 * c.line_green, c.line_pixels,
      100 * c.off_carpet_green, c.off_carpet_pixels);
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
      if (p.carpet_core) c = {40, 200, 40};
      if (p.line_core) c = {255, 255, 255};
      maskImage.at<cv::Vec3b>(v, u) = c;
    }
  }
  cv::Mat out;
  cv::hconcat(std::vector<cv::Mat>{camera::toBgrImage(f.frame), maskImage,
                                   camera::classificationImage(f.frame, table)},
              out);
  return out;
}

void printDrive(const std::string& name, const char* mode, const AppOptions& o,
                const cal::DriveResult& d) {
  fmt::print(
      "drive {:11s} {:>4s} {} frames, light x{:.2f} -> x{:.2f}: {} line frames, precision "
      "{:.1f} % (min {:.1f} %), recall {:.1f} % (min {:.1f} %), frames meeting both {:.1f} %",
      name, mode, o.drive, o.light_from, o.light_to, d.score.frames, 100 * d.score.precision(),
      100 * d.score.min_precision, 100 * d.score.recall(), 100 * d.score.min_recall,
      100.0 * d.score.frames_meeting / std::max(1, d.score.frames));
  if (d.rebuilds > 0) {
    fmt::print("; gain x{:.2f}..x{:.2f}, {} rebuilds", d.min_gain, d.max_gain, d.rebuilds);
  }
  fmt::print("\n");
}

int evaluate(const AppOptions& o, const cal::FitParams& params) {
  rt::SimCamera sim = rt::SimCamera::load(o.camera_preset, o.field_preset);
  std::vector<cal::RealismSetting> settings;
  if (o.settings.empty()) {
    settings = cal::realismSettings();
  } else {
    for (const std::string& n : o.settings)
      settings.push_back(cal::realismSetting(n));
  }
  std::vector<Pose2> posesToUse;
  for (const std::string& p : o.poses)
    posesToUse.push_back(parsePose(p));
  if (posesToUse.empty()) posesToUse = {{0.5, 0.8, 0.3}, {-6.0, 1.5, 0.4}, {7.5, -4.5, 2.2}};
  int failures = 0;
  if (o.frames > 0) {
    fmt::print("{:11s} {:>18s} {:>9s} {:>9s} {:>7s} {:>7s} {:>7s} {:>7s} {:>7s}\n", "setting",
               "pose", "carpet_g", "line_w", "off_g", "points", "prec", "recall", "minrec");
  }
  for (const cal::RealismSetting& s : settings) {
    for (const Pose2& pose : posesToUse) {
      if (o.frames == 0) break;
      const cal::SettingResult r = cal::evaluateSetting(sim, s, pose, o.frames, params, o.shipped);
      const bool ok = r.score.precision() >= 0.9 && r.score.recall() >= 0.85;
      failures += ok ? 0 : 1;
      fmt::print(
          "{:11s} {:>18s} {:8.1f}% {:8.1f}% {:6.1f}% {:7.0f} {:6.1f}% {:6.1f}% {:6.1f}% {}\n",
          s.name, fmt::format("{:.1f},{:.1f},{:.1f}", pose.x, pose.y, pose.phi),
          100 * r.coverage.carpet_green, 100 * r.coverage.line_white,
          100 * r.coverage.off_carpet_green,
          static_cast<double>(r.score.points) / std::max(1, r.score.frames),
          100 * r.score.precision(), 100 * r.score.recall(), 100 * r.score.min_recall,
          ok ? "" : "BELOW");
    }
  }
  for (const cal::RealismSetting& s : settings) {
    if (o.drive == 0) break;
    // Calibrated at the drive's first pose, in the drive's middle light (the geometric mean of
    // its first and last) unless --calibration-light says otherwise.
    const std::vector<Pose2> first =
        rt::motionPoses(sim.field, rt::Motion{.speed = 1.5, .omega = 0.5}, 1);
    cal::RealismSetting start = s;
    start.realism.light_factor =
        s.realism.light_factor *
        (o.calibration_light > 0 ? o.calibration_light : std::sqrt(o.light_from * o.light_to));
    const cal::SettingResult calibrated =
        cal::evaluateSetting(sim, start, first[0], 3, params, o.shipped);
    const camera::ColourTable table(calibrated.calibration.boxes);
    printDrive(s.name, o.adapt ? "off" : "", o,
               cal::evaluateDrive(sim, s, table, o.drive, o.light_from, o.light_to));
    if (o.adapt) {
      rt::ColourAdaptationParams adaptation;
      adaptation.enabled = true;
      adaptation.reference = calibrated.calibration.carpet_median;
      printDrive(s.name, "on", o,
                 cal::evaluateDrive(sim, s, table, o.drive, o.light_from, o.light_to, adaptation));
    }
  }
  if (o.frames > 0) {
    fmt::print("{} setting/pose combinations below precision 90 % or recall 85 %\n", failures);
  }
  return 0;
}

std::vector<cal::UserMask> readMasks(const AppOptions& o, const camera::FrameView& frame) {
  std::vector<cal::UserMask> masks;
  for (const std::string& m : o.masks) {
    const std::size_t eq = m.find('=');
    const auto colour = camera::colourFromName(m.substr(0, eq == std::string::npos ? 0 : eq));
    if (eq == std::string::npos || !colour || *colour == camera::ColourClass::kUnknown) {
      throw std::invalid_argument("--mask expects CLASS=file.png, got " + m);
    }
    const cv::Mat painted = camera::readBgrImage(m.substr(eq + 1));
    if (painted.cols != frame.width || painted.rows != frame.height) {
      throw std::invalid_argument(m + ": the mask must have the frame's size");
    }
    cal::UserMask um{*colour, frame, {}};
    um.mask.resize(static_cast<std::size_t>(painted.cols) * painted.rows);
    for (int v = 0; v < painted.rows; ++v) {
      for (int u = 0; u < painted.cols; ++u) {
        const cv::Vec3b c = painted.at<cv::Vec3b>(v, u);
        um.mask[static_cast<std::size_t>(v) * painted.cols + u] = (c[0] | c[1] | c[2]) != 0;
      }
    }
    masks.push_back(std::move(um));
  }
  if (!o.painted.empty()) {
    std::vector<cal::UserMask> more = masksFromPainting(camera::readBgrImage(o.painted), frame);
    if (more.empty()) {
      throw std::invalid_argument(o.painted +
                                  ": no pixel in a palette colour (see --help of --masks)");
    }
    for (cal::UserMask& m : more)
      masks.push_back(std::move(m));
  }
  return masks;
}

// Writes the table (boxes, or a lookup table with the YAML naming it) only after loading the
// staged files with the loader region tracking uses and comparing what it reads cell by cell.
void writeTable(const AppOptions& o, const camera::ColourTable& table,
                const std::vector<camera::YuvBox>& boxes, const std::string& comment) {
  const bool lut = o.lut || table.fromLookupTable() || boxes.empty();
  StagedFiles staged;
  std::string yamlPath;
  if (lut) {
    const std::filesystem::path lutPath = std::filesystem::path(o.out).replace_extension(".lut");
    std::ostringstream bytes;
    camera::writeColourLookup(bytes, table);
    staged.stage(lutPath.string(), bytes.str());
    std::string yaml;
    std::istringstream lines(comment);
    for (std::string line; std::getline(lines, line);)
      yaml += "# " + line + "\n";
    yaml += "# The full lookup table (docs/calibration.md, lookup table file).\nlookup_table: " +
            lutPath.filename().string() + "\n";
    yamlPath = staged.stage(o.out, yaml);
  } else {
    yamlPath = staged.stage(o.out, cal::colourTableYaml(boxes, comment));
  }
  // Read back through the project's loader: what was written is the table.
  if (camera::loadColourTablePreset(yamlPath).yuvLookup() != table.yuvLookup()) {
    throw Refusal(o.out + " does not read back as the calibrated table");
  }
  for (const std::string& written : staged.commit())
    fmt::print("wrote {}{}\n", written, written.ends_with(".lut") ? " (lookup table)" : "");
}

void printCheck(const cal::TableCheck& check) {
  fmt::print("check: the tracker's line points with this table, fitted to the field:\n");
  fmt::print("{:>6s} {:>7s} {:>26s} {:>10s} {:>10s}\n", "frame", "points", "pose x,y,phi (m, deg)",
             "median cm", "on lines");
  for (std::size_t i = 0; i < check.frames.size(); ++i) {
    const cal::FrameCheck& f = check.frames[i];
    fmt::print("{:6d} {:7d} {:>26s} {:10.1f} {:9.1f}%\n", i + 1, f.line_points,
               f.localized ? fmt::format("{:.2f},{:.2f},{:.1f}", f.pose.x, f.pose.y,
                                         f.pose.phi * 180.0 / std::numbers::pi)
                           : std::string("-"),
               f.median_cm, 100 * f.fit_share);
  }
  fmt::print(
      "all: {} line points, {:.1f} % within 15 cm of a line; median luma white {:.0f}, "
      "green {:.0f}\n",
      check.line_points, 100 * check.fit_share, check.white_luma, check.green_luma);
}

void refuseOnProblems(const cal::TableCheck& check) {
  if (check.problems.empty()) return;
  std::string why;
  for (const std::string& p : check.problems)
    why += "\n  " + p;
  throw Refusal("the table fails its check:" + why);
}

// What the calibration says of the ball: found (its samples, those left out), or why not.
void printBall(const cal::ImageCalibration& c, int localized) {
  const bool posed = localized > 0;
  if (!posed) {
    fmt::print("ball and robots: not searched (no frame fitted the field with the first table)\n");
  } else if (c.ball_found) {
    fmt::print(
        "ball: found in {} of the {} frames that fitted the field, at field ({:.2f}, "
        "{:.2f}), {} samples -> orange ({} left out as the carpet's or the lines' colours)\n",
        c.ball_frames, localized, c.ball_field.x(), c.ball_field.y(), c.samples.ball.size(),
        c.ball_samples_refused);
  } else if (c.ball_samples_refused > 0) {
    fmt::print(
        "ball: its blobs' colours are the carpet's or the lines' ({} samples left out, {} kept): "
        "the table has no ball (orange) class; put the ball 1-3 m from the robot off the lines "
        "and calibrate again\n",
        c.ball_samples_refused, c.samples.ball.size());
  } else {
    fmt::print(
        "ball: none found in the frames: the table has no ball (orange) class; put a "
        "ball 1-3 m from the robot and calibrate again for its colour\n");
  }
}

// The procedure from the frames alone (no pose): floor, lines, a first check that finds the
// poses, ball and robots, the table and its check.
int calibrateFromFrames(const AppOptions& o, const camera::MirrorModel& mirror,
                        const fieldline::field::FieldModel& field,
                        const std::vector<camera::FrameView>& frames) {
  cal::ImageFitParams params;
  params.light_range = {o.light_range[0], o.light_range[1]};
  const cal::FramesCalibration result = cal::calibrateColours(mirror, field, frames, params);
  const cal::ImageCalibration& c = result.calibration;
  const int localized = result.posed;
  const bool posed = localized > 0;
  fmt::print(
      "floor: median y,u,v {:.0f},{:.0f},{:.0f} ({:.0f} % of the floor annulus; chroma sigma "
      "{:.1f} levels; luma p1-p99 {:.0f}-{:.0f}), {} samples\n",
      c.floor.median[0], c.floor.median[1], c.floor.median[2], 100 * c.floor.share,
      c.floor.chroma_sigma, c.floor.luma[0], c.floor.luma[1], c.samples.floor.size());
  fmt::print(
      "lines: {} of {} ridges with floor on both sides, {} samples, luma p5-p95 {:.0f}-{:.0f}, "
      "white point u,v {:.0f},{:.0f}; where their chroma is the floor's: floor up to luma {:.0f}, "
      "white from {:.0f}\n",
      c.line_ridges, c.ridges, c.samples.line.size(), c.line_luma[0], c.line_luma[1],
      c.white_point[0], c.white_point[1], c.luma_boundary, c.white_from);
  printBall(c, localized);
  if (posed) {
    fmt::print("robots: {}\n", c.robots_found
                                   ? fmt::format("{} dark samples -> black", c.samples.robot.size())
                                   : std::string("none in the field: no black class"));
  }
  fmt::print(
      "carpet median y,u,v {:.0f},{:.0f},{:.0f} (adaptation: reference [{:.0f}, {:.0f}, "
      "{:.0f}])\n",
      c.floor.median[0], c.floor.median[1], c.floor.median[2], c.floor.median[0], c.floor.median[1],
      c.floor.median[2]);
  const cal::TableCheck& check = result.check;
  printCheck(check);
  if (!o.debug_png.empty()) {
    // Per frame: the frame | its classes with the tracker's line points (red: on a field line at
    // the fitted pose, yellow: off the lines).
    std::vector<cv::Mat> rows;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      cv::Mat classes = camera::classificationImage(frames[i], c.table);
      const cal::FrameCheck& f = check.frames[i];
      for (std::size_t k = 0; k < f.lines.points.size(); ++k) {
        const bool on = k < f.on_line.size() && f.on_line[k];
        cv::circle(classes,
                   cv::Point(static_cast<int>(std::lround(f.lines.points[k].u)),
                             static_cast<int>(std::lround(f.lines.points[k].v))),
                   1, on ? cv::Scalar(0, 0, 255) : cv::Scalar(0, 255, 255), cv::FILLED);
      }
      cv::Mat row;
      cv::hconcat(std::vector<cv::Mat>{camera::toBgrImage(frames[i]), classes}, row);
      rows.push_back(row);
    }
    cv::Mat out;
    cv::vconcat(rows, out);
    camera::writeImage(o.debug_png, out);
  }
  refuseOnProblems(check);
  if (!o.out.empty()) {
    writeTable(o, c.table, {},
               fmt::format("Colour table from fieldline-colour-calibrate: {} frame(s), camera {}, "
                           "field {}, from the frames alone.\nCheck: {} line points, {:.1f} % "
                           "within 15 cm of the field's lines; ball class: {}.",
                           frames.size(), o.camera_preset, o.field_preset, check.line_points,
                           100 * check.fit_share, c.ball_found ? "from the frames" : "none"));
  }
  return 0;
}

}  // namespace

void AppOptions::addTo(cli::App& app) {
  app.add_option("--camera", camera_preset, "camera preset (image size, mirror, colour table)")
      ->capture_default_str();
  app.add_option("--field", field_preset, "field preset")->capture_default_str();
  app.add_option("--in", inputs, "frame: PNG/JPEG/BMP, or raw YUYV with --yuyv (repeatable)");
  app.add_option("--yuyv", yuyv_size, "the inputs are raw YUYV 4:2:2 of this size, e.g. 320x240");
  app.add_option("--pose", poses,
                 "robot pose x,y,phi (m, m, rad, field frame) of each --in, or one for all, when "
                 "known (optional: without it the colours come from the frames alone)");
  app.add_flag("--render", render, "calibrate from a frame the simulated camera renders at --pose");
  app.add_option("--realism", settings,
                 "realism setting for --render / --evaluate (clean, noise, washed, cast, blur, "
                 "vignetting, uneven, dim, bright, all; repeatable)");
  app.add_option("--mask", masks,
                 "CLASS=mask.png: pixels painted (nonzero) over the first frame are samples of "
                 "CLASS (orange, black, yellow, blue); repeatable");
  app.add_option("--masks", painted,
                 "a PNG painted over the first frame, a colour per class (RGB): ball 255,128,0; "
                 "obstacles 255,0,255; yellow goal 255,230,0; blue goal 20,90,230; not carpet "
                 "and no class (team markers, people) 0,255,255; other pixels ignored");
  app.add_option("--base", base,
                 "colour table (boxes or lookup table) whose other classes are kept (default: the "
                 "camera's)");
  app.add_option("--out", out,
                 "colour YAML to write (with OUT.lut beside it for a lookup table), only when "
                 "the table passes its check");
  app.add_flag("--lut", lut,
               "write the full lookup table (OUT with .lut) and a YAML naming it, not boxes");
  app.add_option("--debug-png", debug_png,
                 "write input | predicted masks | classes of the first frame");
  app.add_option("--save-frame", save_frame, "write the (first) frame as PNG");
  app.add_flag("--evaluate", evaluate,
               "measure: per realism setting and pose, calibrate from one rendered frame, track, "
               "score the line points against the field model");
  app.add_option("--frames", frames, "frames tracked per setting and pose in --evaluate (0: none)")
      ->check(cli::Range(0, 1000))
      ->capture_default_str();
  app.add_option("--drive", drive, "also drive this many frames with the light changing")
      ->check(cli::Range(0, 100000));
  app.add_option("--light-from", light_from, "light factor at the drive's start")
      ->capture_default_str();
  app.add_option("--light-to", light_to, "light factor at the drive's end")->capture_default_str();
  app.add_option("--calibration-light", calibration_light,
                 "light factor of the drive's calibration frame (default: the geometric mean of "
                 "--light-from and --light-to)");
  app.add_flag("--adapt", adapt,
               "drive twice: colour adaptation off, then on (green and white follow the light)");
  app.add_option("--light-range", light_range,
                 "the table holds for the calibration light times LOW..HIGH (1 1: only that light)")
      ->expected(2)
      ->capture_default_str();
  app.add_flag("--shipped", shipped,
               "--evaluate the camera's own colour table instead of calibrating (comparison)");
}

const std::vector<PaintColour>& paintPalette() {
  static const std::vector<PaintColour> palette = {
      {camera::ColourClass::kOrange, 255, 128, 0},  {camera::ColourClass::kBlack, 255, 0, 255},
      {camera::ColourClass::kYellow, 255, 230, 0},  {camera::ColourClass::kBlue, 20, 90, 230},
      {camera::ColourClass::kUnknown, 0, 255, 255},
  };
  return palette;
}

std::vector<UserMask> masksFromPainting(const cv::Mat& painted, const camera::FrameView& frame,
                                        int min_pixels) {
  if (painted.type() != CV_8UC3 || painted.cols != frame.width || painted.rows != frame.height) {
    throw std::invalid_argument(
        fmt::format("the painted masks must be a colour image of the frame's size {}x{}, got {}x{}",
                    frame.width, frame.height, painted.cols, painted.rows));
  }
  std::vector<UserMask> masks;
  for (const PaintColour& p : paintPalette()) {
    UserMask m{p.colour, frame, std::vector<std::uint8_t>(frame.width * frame.height, 0)};
    int count = 0;
    for (int v = 0; v < painted.rows; ++v) {
      for (int u = 0; u < painted.cols; ++u) {
        const cv::Vec3b c = painted.at<cv::Vec3b>(v, u);
        if (std::abs(c[2] - p.r) <= 6 && std::abs(c[1] - p.g) <= 6 && std::abs(c[0] - p.b) <= 6) {
          m.mask[static_cast<std::size_t>(v) * frame.width + u] = 1;
          ++count;
        }
      }
    }
    if (count >= min_pixels) masks.push_back(std::move(m));
  }
  return masks;
}

camera::ColourTable finalTable(const Calibration& calibration, const camera::ColourTable& base) {
  if (!base.fromLookupTable()) return camera::ColourTable(calibration.boxes);
  // The lookup table's cells of the calibrated classes are dropped: the new boxes replace them.
  std::vector<camera::ColourClass> cells = base.yuvLookup();
  for (camera::ColourClass& c : cells) {
    for (const ClassFit& f : calibration.fits) {
      if (f.colour == c) c = camera::ColourClass::kUnknown;
    }
  }
  return camera::ColourTable(calibration.boxes, camera::ColourTable::fromLookup(std::move(cells)));
}

namespace {

// The frames and what their views point into.
struct Frames {
  std::vector<std::vector<std::uint8_t>> raw;
  std::vector<camera::FrameFile> files;
  std::optional<camera::SimRenderer> renderer;
  std::vector<cal::PosedFrame> posed;
};

// --render: frames rendered at the given poses.
void renderFrames(const AppOptions& o, const camera::CameraConfig& config,
                  const fieldline::field::FieldModel& field, Frames& frames) {
  auto& raw = frames.raw;
  auto& renderer = frames.renderer;
  auto& posed = frames.posed;
  if (o.poses.empty()) throw std::invalid_argument("--render needs --pose");
  camera::RenderParams render = camera::renderParamsOf(config, "--render");
  if (!o.settings.empty()) render.realism = cal::realismSetting(o.settings[0]).realism;
  if (o.settings.size() > 1) throw std::invalid_argument("--render takes one --realism");
  if (!o.inputs.empty()) throw std::invalid_argument("--render and --in exclude each other");
  renderer.emplace(config.model.mirror, field, render);
  raw.reserve(o.poses.size());
  for (const std::string& p : o.poses) {
    camera::SimScene scene;
    scene.robot = parsePose(p);
    raw.emplace_back();
    renderer->render(scene, raw.back());
    posed.push_back({renderer->view(raw.back()), scene.robot});
  }
}

// --in: frames read from files, with no pose, one, or one each.
void readFrames(const AppOptions& o, Frames& frames) {
  auto& files = frames.files;
  auto& posed = frames.posed;
  if (o.inputs.empty()) throw std::invalid_argument("give --in frames (or --render --pose)");
  if (!o.poses.empty() && o.poses.size() != 1 && o.poses.size() != o.inputs.size()) {
    throw std::invalid_argument("give no --pose, one, or one per --in");
  }
  std::optional<camera::FrameSize> size;
  if (!o.yuyv_size.empty()) size = camera::parseFrameSize(o.yuyv_size);
  files.reserve(o.inputs.size());
  for (std::size_t i = 0; i < o.inputs.size(); ++i) {
    files.push_back(camera::readFrameFile(o.inputs[i], size));
    Pose2 pose;
    if (!o.poses.empty()) pose = parsePose(o.poses.size() == 1 ? o.poses[0] : o.poses[i]);
    posed.push_back({files.back().view(), pose});
  }
}

// Known poses: the field model predicts carpet and line pixels (docs/calibration.md).
int calibrateAtKnownPoses(const AppOptions& o, const camera::CameraConfig& config,
                          const fieldline::field::FieldModel& field,
                          const std::vector<cal::PosedFrame>& posed, const cal::FitParams& params) {
  const camera::MirrorModel& mirror = config.model.mirror;
  camera::ColourTable base =
      camera::loadColourTablePreset(o.base.empty() ? config.model.colour_table : o.base);
  const std::vector<cal::UserMask> masks = readMasks(o, posed[0].frame);
  const cal::Calibration calibration =
      cal::calibrate(mirror, field, posed, masks, base.boxes(), params);
  const camera::ColourTable table = finalTable(calibration, base);
  printFits(calibration);
  fmt::print(
      "carpet median y,u,v {:.0f},{:.0f},{:.0f} (adaptation: reference [{:.0f}, {:.0f}, {:.0f}])\n",
      calibration.carpet_median[0], calibration.carpet_median[1], calibration.carpet_median[2],
      calibration.carpet_median[0], calibration.carpet_median[1], calibration.carpet_median[2]);
  printCoverage(cal::measureCoverage(mirror, field, posed, table, params.masks));
  if (!o.debug_png.empty()) {
    camera::writeImage(o.debug_png, debugImage(mirror, field, posed[0], table, params.masks));
  }
  std::vector<camera::FrameView> views;
  for (const cal::PosedFrame& f : posed)
    views.push_back(f.frame);
  const cal::TableCheck check = cal::checkTable(mirror, field, views, table, cal::ImageFitParams{});
  printCheck(check);
  refuseOnProblems(check);
  if (!o.out.empty()) {
    writeTable(o, table,
               o.lut || table.fromLookupTable() ? std::vector<camera::YuvBox>{} : calibration.boxes,
               fmt::format("Colour table from fieldline-colour-calibrate ({} frame(s), camera "
                           "{}, field {}).\nWhite and green fitted from the field model's "
                           "prediction at the given pose(s); other classes kept.",
                           posed.size(), o.camera_preset, o.field_preset));
  }
  return 0;
}

}  // namespace

int runApp(const AppOptions& o) {
  cal::FitParams params;
  params.light_range = {o.light_range[0], o.light_range[1]};
  if (o.evaluate) return evaluate(o, params);
  // Any camera preset: the mirror tool's output (no render section) as well as a simulated one.
  const camera::CameraConfig config = camera::loadCameraConfigPreset(o.camera_preset);
  const fieldline::field::FieldModel field = fieldline::field::loadFieldPreset(o.field_preset);
  Frames frames;
  const std::vector<cal::PosedFrame>& posed = frames.posed;
  if (o.render) {
    renderFrames(o, config, field, frames);
  } else {
    readFrames(o, frames);
  }
  const camera::MirrorModel& mirror = config.model.mirror;
  for (const cal::PosedFrame& f : posed) {
    if (f.frame.width != mirror.width() || f.frame.height != mirror.height()) {
      throw std::invalid_argument(fmt::format(
          "a frame is {}x{}, the camera preset {} is for {}x{}: give the camera's own preset "
          "(fieldline-mirror-calibrate writes one)",
          f.frame.width, f.frame.height, o.camera_preset, mirror.width(), mirror.height()));
    }
  }
  if (!o.save_frame.empty()) camera::writeImage(o.save_frame, camera::toBgrImage(posed[0].frame));
  if (o.poses.empty()) {
    std::vector<camera::FrameView> views;
    for (const cal::PosedFrame& f : posed)
      views.push_back(f.frame);
    return calibrateFromFrames(o, mirror, field, views);
  }
  return calibrateAtKnownPoses(o, config, field, posed, params);
}

}  // namespace fieldline::calibration
