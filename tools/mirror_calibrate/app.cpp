#include "tools/mirror_calibrate/app.hpp"

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "common/camera/image_io.hpp"
#include "common/config/config.hpp"
#include "common/field/field_model.hpp"
#include "services/camera/camera_config.hpp"
#include "tools/colour_calibrate/evaluation.hpp"
#include "tools/mirror_calibrate/evaluation.hpp"

namespace fieldline::calibration {
namespace {

std::vector<double> numbers(const std::string& text, std::size_t count, const std::string& what) {
  std::vector<double> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    std::size_t used = 0;
    double v = 0.0;
    try {
      v = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != item.size() || !std::isfinite(v)) {
      throw std::invalid_argument(what + ": '" + item + "' is not a number");
    }
    out.push_back(v);
  }
  if (out.size() != count) {
    throw std::invalid_argument(
        fmt::format("{}: expected {} comma-separated numbers, got '{}'", what, count, text));
  }
  return out;
}

GreyImage greyFromMat(const cv::Mat& bgr) {
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  GreyImage g{grey.cols, grey.rows, {}};
  g.pixels.reserve(static_cast<std::size_t>(grey.cols) * grey.rows);
  for (int v = 0; v < grey.rows; ++v) {
    for (int u = 0; u < grey.cols; ++u)
      g.pixels.push_back(grey.at<std::uint8_t>(v, u));
  }
  return g;
}

// Ring points (by ring, outliers red), the fitted rings and the centre | radius vs distance per
// sector with the ring knots.
cv::Mat debugImage(const GreyImage& image, const RingCalibration& c) {
  cv::Mat grey(image.height, image.width, CV_8UC1, const_cast<std::uint8_t*>(image.pixels.data()));
  cv::Mat left;
  cv::cvtColor(grey, left, cv::COLOR_GRAY2BGR);
  const int scale = image.width < 400 ? 2 : 1;
  cv::resize(left, left, cv::Size(), scale, scale, cv::INTER_NEAREST);
  const cv::Scalar palette[] = {{255, 80, 0},    {0, 200, 0},   {0, 200, 255}, {255, 0, 255},
                                {255, 255, 0},   {0, 128, 255}, {128, 255, 0}, {255, 128, 128},
                                {128, 128, 255}, {0, 255, 128}};
  auto px = [scale](const Vec2& p) {
    return cv::Point(static_cast<int>(std::lround((p.x() + 0.5) * scale - 0.5)),
                     static_cast<int>(std::lround((p.y() + 0.5) * scale - 0.5)));
  };
  const camera::MirrorModel mirror(c.mirror);
  for (std::size_t i = 0; i < c.points.size(); ++i) {
    const bool in = c.fit.inlier.empty() || c.fit.inlier[i];
    const cv::Scalar colour = in ? palette[c.points[i].ring % 10] : cv::Scalar(0, 0, 255);
    cv::circle(left, px(c.points[i].pixel), 0, colour, scale);
  }
  for (std::size_t k = 0; k < c.distances.size(); ++k) {
    for (int deg = 0; deg < 360; deg += 2) {
      const double b = deg * std::numbers::pi / 180.0;
      const double r = c.fit.ringRadius(static_cast<int>(k), b);
      const Vec2 p = c.fit.centre + r * mirror.imageDirection(b);
      if (deg % 30 == 0) cv::circle(left, px(p), 1, cv::Scalar(255, 255, 255), 1);
    }
    // Labels spread over bearings so that close outer rings stay readable.
    const double lb = 0.35 * static_cast<double>(k) - 0.5;
    const Vec2 label =
        c.fit.centre + c.fit.ringRadius(static_cast<int>(k), lb) * mirror.imageDirection(lb);
    cv::putText(left, fmt::format("{:g}", c.distances[k]), px(label), cv::FONT_HERSHEY_PLAIN, 0.8,
                cv::Scalar(0, 255, 255), 1);
  }
  cv::drawMarker(left, px(c.fit.centre), cv::Scalar(0, 0, 255), cv::MARKER_CROSS, 12, 1);
  // Right: radius (x) against distance (y), one curve per sector, knots as dots.
  const int h = left.rows;
  const int w = h;
  cv::Mat right(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  const double rMax = c.mirror.useful_radius * 1.05;
  const double dMax = c.distances.back() * 1.1;
  auto plot = [&](double r, double d) {
    return cv::Point(static_cast<int>(30 + (w - 40) * r / rMax),
                     static_cast<int>(h - 30 - (h - 40) * d / dMax));
  };
  cv::line(right, plot(0, 0), plot(rMax, 0), cv::Scalar(0, 0, 0));
  cv::line(right, plot(0, 0), plot(0, dMax), cv::Scalar(0, 0, 0));
  for (double d = 1.0; d < dMax; d += 1.0) {
    cv::line(right, plot(0, d), plot(rMax, d), cv::Scalar(220, 220, 220));
    cv::putText(right, fmt::format("{:g} m", d), plot(0, d) + cv::Point(2, -2),
                cv::FONT_HERSHEY_PLAIN, 0.8, cv::Scalar(0, 0, 0));
  }
  for (double r = 50.0; r < rMax; r += 50.0) {
    cv::putText(right, fmt::format("{:g}", r), plot(r, 0) + cv::Point(-8, 14),
                cv::FONT_HERSHEY_PLAIN, 0.8, cv::Scalar(0, 0, 0));
  }
  cv::putText(right, "image radius (px)", cv::Point(w / 2 - 60, h - 4), cv::FONT_HERSHEY_PLAIN, 0.9,
              cv::Scalar(0, 0, 0));
  const auto& t = c.table.table;
  for (std::size_t s = 0; s < t.sector_bearings.size(); ++s) {
    for (std::size_t i = 1; i < t.radii.size(); ++i) {
      cv::line(right, plot(t.radii[i - 1], t.distances[s][i - 1]),
               plot(t.radii[i], t.distances[s][i]), palette[s % 10], 1);
    }
  }
  for (std::size_t k = 0; k < c.distances.size(); ++k) {
    cv::circle(right, plot(c.fit.radii[k], c.distances[k]), 3, cv::Scalar(0, 0, 0), 1);
  }
  cv::Mat out;
  cv::hconcat(std::vector<cv::Mat>{left, right}, out);
  return out;
}

void printReport(const RingCalibration& c) {
  fmt::print("rings found: {} (radii", c.found_radii.size());
  for (double r : c.found_radii)
    fmt::print(" {:.1f}", r);
  fmt::print(" px)\nmatched: ring {}.. = distance {}.. ({} rings, cubic misfit {:.2f} %)\n",
             c.match.first_ring + 1, c.match.first_distance + 1, c.match.count,
             100 * c.match.misfit);
  fmt::print(
      "centre ({:.2f}, {:.2f}) px, axis offset ({:.3f}, {:.3f}) m, rms {:.2f} px over {} "
      "points ({} outliers)\n",
      c.fit.centre.x(), c.fit.centre.y(), c.fit.axis_offset.x(), c.fit.axis_offset.y(),
      c.fit.rms_px, c.fit.inliers, c.fit.outliers);
  fmt::print("ring radii (px):");
  for (std::size_t k = 0; k < c.distances.size(); ++k)
    fmt::print(" {:g} m {:.2f}", c.distances[k], c.fit.radii[k]);
  fmt::print("\n{:>8s} {:>7s} {:>6s} {:>8s} {:>8s} {:>8s} {:>8s}\n", "bearing", "points", "rings",
             "rms_px", "rms_%", "max_%", "max_cm");
  auto row = [](const std::string& name, const SectorResidual& r) {
    fmt::print("{:>8s} {:7d} {:6d} {:8.2f} {:8.2f} {:8.2f} {:8.1f}\n", name, r.points, r.rings,
               r.rms_px, r.rms_percent, r.max_percent, r.max_cm);
  };
  for (const SectorResidual& r : c.table.residuals)
    row(fmt::format("{:.0f}°", r.bearing * 180.0 / std::numbers::pi), r);
  row("all", c.table.total);
}

}  // namespace

void MirrorCalibrateOptions::addTo(CLI::App& app) {
  auto* in = app.add_option("--rings", rings, "Image of the ring carpet (PNG, JPEG, BMP)");
  app.add_flag("--render-rings", render_rings,
               "Calibrate from a rendered ring carpet (the camera's mirror, moved by "
               "--render-centre-shift and --render-offset, with --realism)")
      ->excludes(in);
  app.add_option("--lines", lines,
                 "A frame of the field at a known pose (repeatable; one --pose each)")
      ->excludes(in);
  app.add_option("--pose", poses, "The robot's field pose x,y,phi of each --lines frame");
  app.add_flag("--render-lines", render_lines,
               "Calibrate from rendered field frames at the --pose poses (default four poses)");
  app.add_option("--field", field, "Field preset of the --lines frames")->capture_default_str();
  app.add_option("--distances", distances,
                 "Ring distances from the robot's centre: 1,1.5,2 (m) or a file with "
                 "`distN = <mm>` lines (default for --render-rings: the rendered carpet's)");
  app.add_option("--camera", camera, "Base camera preset (name or path)")->capture_default_str();
  app.add_option("--min-radius", min_radius, "Search rings from this radius, px (0: self_radius)");
  app.add_option("--max-radius", max_radius,
                 "Search rings up to this radius, px (0: outer_radius)");
  app.add_option("--min-contrast", min_contrast, "Grey levels a ring stands above the floor")
      ->capture_default_str();
  app.add_option("--sectors", sectors, "Bearing sectors of the table")->capture_default_str();
  app.add_option("--radius-step", radius_step, "Table radii spacing, px")->capture_default_str();
  app.add_flag("--no-offset", no_offset, "Keep the axis offset at 0 (do not fit it)");
  app.add_option("--render-centre-shift", render_centre_shift, "du,dv px")->capture_default_str();
  app.add_option("--render-offset", render_offset, "x,y m")->capture_default_str();
  app.add_option("--realism", realism, "Realism setting of the rendered carpet")
      ->capture_default_str();
  app.add_option("--out", out, "Write the camera YAML here");
  app.add_option("--debug-png", debug_png, "Write the rings found and the fitted table here");
}

namespace {

geometry::Pose2 parsePose(const std::string& text) {
  const std::vector<double> p = numbers(text, 3, "--pose");
  return {p[0], p[1], p[2]};
}

void printLineReport(const LineCalibration& c) {
  fmt::print("{} ridge pixels, {} on field lines\n", c.candidates, c.points);
  fmt::print("centre ({:.2f}, {:.2f}) px, axis offset ({:.3f}, {:.3f}) m\nradii (px):",
             c.centre.x(), c.centre.y(), c.axis_offset.x(), c.axis_offset.y());
  for (std::size_t k = 0; k < c.knot_distances.size(); ++k)
    fmt::print(" {:g} m {:.2f}", c.knot_distances[k], c.knot_radii[k]);
  fmt::print("\n{:>8s} {:>7s} {:>8s} {:>8s}\n", "bearing", "points", "rms_px", "rms_cm");
  auto row = [](const std::string& name, const LineSectorResidual& r) {
    fmt::print("{:>8s} {:7d} {:8.2f} {:8.1f}\n", name, r.points, r.rms_px, r.rms_cm);
  };
  for (const LineSectorResidual& r : c.residuals)
    row(fmt::format("{:.0f}°", r.bearing * 180.0 / std::numbers::pi), r);
  row("all", c.total);
}

// Writes the camera preset and reads it back through the camera service's loader.
void writePreset(const MirrorCalibrateOptions& o, const camera::CameraConfig& config,
                 const camera::MirrorParams& mirror, const std::string& comment) {
  const std::string yaml = cameraYaml(mirror, config.model.colour_table, config.pipeline.frame_rate,
                                      config.pipeline.exposure, config.pipeline.latency, comment);
  std::ofstream file(o.out);
  file << yaml;
  file.close();
  if (!file) throw std::runtime_error("cannot write " + o.out);
  (void)camera::loadCameraConfigPreset(o.out);
  fmt::print("wrote {}\n", o.out);
}

// --lines / --render-lines: the calibration from field lines at known poses.
int runLines(const MirrorCalibrateOptions& o, const camera::CameraConfig& config) {
  const camera::MirrorParams base = config.model.mirror.params();
  const field::FieldModel field = field::loadFieldPreset(o.field);
  std::vector<geometry::Pose2> poses;
  for (const std::string& p : o.poses)
    poses.push_back(parsePose(p));
  std::vector<PosedImage> frames;
  std::optional<camera::MirrorModel> truth;
  if (o.render_lines) {
    if (poses.empty())
      poses = {{-6.0, 1.5, 0.4}, {0.5, 0.8, 0.3}, {-3.5, -2.5, 2.0}, {4.0, 3.0, -1.0}};
    camera::MirrorParams t = base;
    const std::vector<double> shift = numbers(o.render_centre_shift, 2, "--render-centre-shift");
    const std::vector<double> offset = numbers(o.render_offset, 2, "--render-offset");
    t.centre += Vec2(shift[0], shift[1]);
    t.axis_offset = Vec2(offset[0], offset[1]);
    truth.emplace(t);
    frames = renderFieldFrames(*truth, field, camera::renderParamsOf(config, "--render-lines"),
                               poses, realismSetting(o.realism).realism);
  } else {
    if (poses.size() != o.lines.size()) {
      throw std::invalid_argument(
          fmt::format("{} --lines frames but {} --pose values", o.lines.size(), poses.size()));
    }
    for (std::size_t i = 0; i < o.lines.size(); ++i)
      frames.push_back({greyFromMat(camera::readBgrImage(o.lines[i])), poses[i]});
  }
  LineFitParams params;
  params.sectors = o.sectors;
  params.radius_step = o.radius_step;
  params.fit_offset = !o.no_offset;
  params.search.min_contrast = o.min_contrast;
  const LineCalibration c = calibrateFromLines(frames, field, base, params);
  printLineReport(c);
  if (truth) {
    const MirrorError e = compareMirrors(*truth, camera::MirrorModel(c.mirror), 5.0);
    fmt::print(
        "against the rendered truth: centre {:.2f} px, axis offset {:.1f} cm, distance "
        "function up to 5 m {:.2f} %, floor points up to 5 m {:.1f} cm\n",
        e.centre_px, 100 * e.offset_m, e.distance_percent, 100 * e.floor_point_m);
  }
  if (!o.out.empty()) {
    writePreset(o, config, c.mirror,
                fmt::format("Written by fieldline-mirror-calibrate from {} field frame(s) (base "
                            "preset {}).\nResiduals: rms {:.2f} px, {:.1f} cm to the lines.",
                            frames.size(), o.camera, c.total.rms_px, c.total.rms_cm));
  }
  return 0;
}

}  // namespace

int runMirrorCalibrate(const MirrorCalibrateOptions& o) {
  const int inputs = (o.rings.empty() ? 0 : 1) + (o.render_rings ? 1 : 0) +
                     (o.lines.empty() ? 0 : 1) + (o.render_lines ? 1 : 0);
  if (inputs != 1) {
    throw std::invalid_argument(
        "give one of --rings IMAGE, --render-rings, --lines FRAME --pose x,y,phi, --render-lines");
  }
  const camera::CameraConfig config = camera::loadCameraConfigPreset(o.camera);
  if (!o.lines.empty() || o.render_lines) return runLines(o, config);
  camera::MirrorParams base = config.model.mirror.params();
  GreyImage image;
  std::vector<double> distances;
  std::optional<camera::MirrorModel> truth;
  if (o.render_rings) {
    camera::MirrorParams t = base;
    const std::vector<double> shift = numbers(o.render_centre_shift, 2, "--render-centre-shift");
    const std::vector<double> offset = numbers(o.render_offset, 2, "--render-offset");
    t.centre += Vec2(shift[0], shift[1]);
    t.axis_offset = Vec2(offset[0], offset[1]);
    truth.emplace(t);
    RingCarpet carpet;
    if (!o.distances.empty()) carpet.distances = parseDistances(o.distances);
    distances = carpet.distances;
    image = renderRingCarpet(*truth, carpet, realismSetting(o.realism).realism, 0);
  } else {
    image = greyFromMat(camera::readBgrImage(o.rings));
    if (o.distances.empty()) throw std::invalid_argument("--rings needs --distances");
    distances = parseDistances(o.distances);
    if (image.width != base.width || image.height != base.height) {
      // Another camera: the image's size, its middle as the first centre guess, the search
      // radii from the options; heading, mirror sense and reference height from the preset.
      if (o.min_radius <= 0.0 || o.max_radius <= 0.0) {
        throw std::invalid_argument(fmt::format(
            "the image is {}x{}, the camera preset {}x{}: give --min-radius and --max-radius "
            "(px) for this camera",
            image.width, image.height, base.width, base.height));
      }
      base.width = image.width;
      base.height = image.height;
      base.centre = Vec2((image.width - 1) / 2.0, (image.height - 1) / 2.0);
      base.self_radius = o.min_radius;
      base.outer_radius = o.max_radius;
      base.useful_radius = o.max_radius;
      base.distance = camera::DistanceFunction(camera::LinearExponentialParams{});
    }
  }
  RingCalibrationParams params;
  params.search.min_radius = o.min_radius > 0.0 ? o.min_radius : base.self_radius;
  params.search.max_radius = o.max_radius > 0.0 ? o.max_radius : base.outer_radius;
  params.search.min_contrast = o.min_contrast;
  params.sectors = o.sectors;
  params.radius_step = o.radius_step;
  params.fit.fit_offset = !o.no_offset;
  const RingCalibration c = calibrateFromRings(image, distances, base, params);
  printReport(c);
  const camera::MirrorModel fitted(c.mirror);
  if (truth) {
    const MirrorError e = compareMirrors(*truth, fitted, 5.0);
    fmt::print(
        "against the rendered truth: centre {:.2f} px, axis offset {:.1f} cm, distance "
        "function up to 5 m {:.2f} %, floor points up to 5 m {:.1f} cm\n",
        e.centre_px, 100 * e.offset_m, e.distance_percent, 100 * e.floor_point_m);
  }
  if (!o.debug_png.empty()) {
    camera::writeImage(o.debug_png, debugImage(image, c));
    fmt::print("wrote {}\n", o.debug_png);
  }
  if (!o.out.empty()) {
    writePreset(
        o, config, c.mirror,
        fmt::format("Written by fieldline-mirror-calibrate from {} (base preset {}).\n"
                    "Residuals of the table: rms {:.2f} px, {:.2f} % of the distance, max "
                    "{:.2f} %.",
                    o.render_rings ? "a rendered ring carpet" : o.rings, o.camera,
                    c.table.total.rms_px, c.table.total.rms_percent, c.table.total.max_percent));
  }
  return 0;
}

}  // namespace fieldline::calibration
