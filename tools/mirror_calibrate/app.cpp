#include "tools/mirror_calibrate/app.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
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
#include "tools/calibration_common/percentile.hpp"
#include "tools/calibration_common/staged_output.hpp"
#include "tools/colour_calibrate/evaluation.hpp"
#include "tools/eval_real/venue_cases.hpp"
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

geometry::Pose2 parsePose(const std::string& text) {
  const std::vector<double> p = numbers(text, 3, "--pose");
  return {p[0], p[1], p[2]};
}

std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

void printPoseFreeReport(const PoseFreeCalibration& c) {
  fmt::print("ridge pixels: {} in {} frame(s)\n", c.ridge_pixels, c.frames.size());
  if (c.rim_found) {
    fmt::print("mirror rim: centre ({:.2f}, {:.2f}) px, radius {:.1f} px\n", c.rim_centre.x(),
               c.rim_centre.y(), c.rim_radius);
  } else {
    fmt::print("mirror rim: not visible (the base camera's centre is the first guess)\n");
  }
  fmt::print(
      "search: {} candidate mirrors; winner: radii x{:.2f}, distances x{:.2f} of the base "
      "camera's, cost {:.3f} (runner-up {:.3f}; 0 = all pixels on lines, 1 = none)\n",
      c.search.candidates, c.search.radius_scale, c.search.distance_scale, c.search.score,
      c.search.runner_up);
  fmt::print("{:>16s} {:>4s} {:>26s} {:>24s} {:>7s} {:>7s} {:>8s}\n", "frame", "spot",
             "pose x,y,phi (m, deg)", "sigma (cm, cm, deg)", "points", "rms_px", "on_lines");
  for (const FramePose& f : c.frames) {
    fmt::print("{:>16s} {:>4s} {:>26s} {:>24s} {:7d} {:7.2f} {:7.1f}%\n",
               f.name.size() > 16 ? f.name.substr(f.name.size() - 16) : f.name,
               f.spot >= 0 ? std::to_string(f.spot) : "-",
               fmt::format("{:.3f},{:.3f},{:.1f}", f.pose.x, f.pose.y,
                           f.pose.phi * 180.0 / std::numbers::pi),
               fmt::format("{:.1f}, {:.1f}, {:.2f}", 100 * f.sigma(0), 100 * f.sigma(1),
                           f.sigma(2) * 180.0 / std::numbers::pi),
               f.points, f.rms_px, 100 * f.on_lines);
  }
  fmt::print("(each pose's twin, the field turned by 180 degrees, fits exactly as well)\n");
  fmt::print("centre ({:.2f}, {:.2f}) px (sigma {:.2f} px)\n", c.mirror.centre.x(),
             c.mirror.centre.y(), c.centre_sigma_px);
  fmt::print("axis offset ({:.3f}, {:.3f}) m: {}\n", c.offset.x(), c.offset.y(), c.offset_note);
  fmt::print("tilt: the horizon {:.2f} px further out toward image angle {:.0f}°\n",
             c.tilt_px.norm(), std::atan2(c.tilt_px.y(), c.tilt_px.x()) * 180.0 / std::numbers::pi);
  fmt::print("knots (radius px: distance m, line pixels):");
  for (std::size_t k = 0; k < c.knot_distances.size(); ++k) {
    fmt::print(" {:.1f}: {:.2f} ({})", c.knot_radii[k], c.knot_distances[k], c.knot_support[k]);
  }
  fmt::print(
      "\ntable up to {:.2f} m ({:.1f} px); {} line pixels used, rms {:.2f} px / {:.1f} cm, "
      "{:.1f} % of the ridge pixels in range on lines\n",
      c.table_end_m, c.mirror.useful_radius, c.used, c.rms_px, c.rms_cm, 100 * c.on_lines);
  fmt::print("line width: {:.2f} times the field's (median over {} near line pixels)\n",
             c.line_width_ratio, c.width_samples);
  if (c.search.non_finite_points > 0) {
    fmt::print("{} refusals of non-finite robot-frame points (never measured against the field)\n",
               c.search.non_finite_points);
  }
}

// Writes the camera preset only after reading it back through the camera service's loader and
// checking what was read; returns the exit code.
int writePreset(const MirrorCalibrateOptions& o, const camera::CameraConfig& config,
                const camera::MirrorParams& mirror, double min_reach, const std::string& comment) {
  const std::string yaml = cameraYaml(mirror, colourTableFor(o.out, config.model.colour_table),
                                      config.pipeline.frame_rate, config.pipeline.exposure,
                                      config.pipeline.latency, comment);
  StagedFiles staged;
  staged.stage(o.out, yaml);
  // The loader the camera service uses, resolving paths against where the file will be.
  const camera::CameraConfig loaded =
      camera::loadCameraConfig(config::Node::loadString(yaml, o.out));
  const std::vector<std::string> problems = mirrorProblems(loaded.model.mirror.params(), min_reach);
  if (!problems.empty()) {
    std::string why;
    for (const std::string& p : problems)
      why += "\n  " + p;
    throw Refusal(o.out + " would not be a usable mirror:" + why);
  }
  for (const std::string& written : staged.commit())
    fmt::print("wrote {}\n", written);
  return 0;
}

}  // namespace

std::vector<RingCheck> checkRings(const RingCalibration& c, int sectors) {
  const camera::MirrorModel model(c.mirror);
  std::vector<RingCheck> out(c.distances.size());
  std::vector<std::vector<std::vector<double>>> bySector(
      c.distances.size(), std::vector<std::vector<double>>(static_cast<std::size_t>(sectors)));
  std::vector<std::vector<double>> all(c.distances.size());
  for (std::size_t i = 0; i < c.points.size(); ++i) {
    if (!c.fit.inlier.empty() && !c.fit.inlier[i]) continue;
    const RingPoint& p = c.points[i];
    const double b = model.bearingOf(p.pixel);
    const double t =
        axisDistanceToRing(c.distances[static_cast<std::size_t>(p.ring)], b, c.mirror.axis_offset);
    const double d = c.mirror.distance.floorDistance(model.radiusOf(p.pixel), b);
    if (!std::isfinite(t) || !std::isfinite(d)) continue;
    const double e = 100.0 * (d - t) / t;
    all[static_cast<std::size_t>(p.ring)].push_back(e);
    const int s = std::clamp(
        static_cast<int>(std::floor((b + std::numbers::pi) / (2 * std::numbers::pi) * sectors)), 0,
        sectors - 1);
    bySector[static_cast<std::size_t>(p.ring)][static_cast<std::size_t>(s)].push_back(e);
  }
  // Each inner ring left out: the curve through (0, 0) and the other rings' radii, read at its
  // radius.
  for (std::size_t k = 0; k + 1 < c.distances.size(); ++k) {
    std::vector<double> r{0.0}, d{0.0};
    for (std::size_t j = 0; j < c.distances.size(); ++j) {
      if (j == k) continue;
      r.push_back(c.fit.radii[j]);
      d.push_back(c.distances[j]);
    }
    const double at = MonotoneCurve(r, d)(c.fit.radii[k]);
    out[k].held_out_percent = 100.0 * std::abs(at - c.distances[k]) / c.distances[k];
  }
  for (std::size_t k = 0; k < c.distances.size(); ++k) {
    out[k].distance = c.distances[k];
    out[k].points = static_cast<int>(all[k].size());
    if (all[k].empty()) continue;
    out[k].median_percent = std::abs(upperMedian(all[k]));
    for (const auto& v : bySector[k]) {
      if (v.size() >= 5) {
        out[k].worst_sector_percent =
            std::max(out[k].worst_sector_percent, std::abs(upperMedian(v)));
      }
    }
  }
  return out;
}

camera::MirrorParams ringBaseFor(const GreyImage& image, camera::MirrorParams base,
                                 double min_radius, double max_radius) {
  if (image.width == base.width && image.height == base.height) return base;
  // Another camera: the base scaled to the image's size, its distance function only a shape
  // (the rings fix it); the search reaches from the scaled reflection to the rim.
  base = scaleMirrorTo(base, image.width, image.height);
  base.centre = Vec2((image.width - 1) / 2.0, (image.height - 1) / 2.0);
  base.outer_radius = std::min(image.width, image.height) / 2.0 - 2.0;
  base.useful_radius = base.outer_radius;
  if (const std::optional<Rim> rim = findMirrorRim(image, base.centre, 0.5 * base.outer_radius,
                                                   std::hypot(image.width, image.height) / 2.0)) {
    base.centre = rim->centre;
    base.outer_radius = base.useful_radius = rim->radius - 2.0;
  }
  if (min_radius > 0.0) base.self_radius = min_radius;
  if (max_radius > 0.0) base.outer_radius = base.useful_radius = max_radius;
  return base;
}

std::string colourTableFor(const std::string& out_path, const std::string& colour_table) {
  namespace fs = std::filesystem;
  const bool isPath = colour_table.find('/') != std::string::npos ||
                      (colour_table.size() > 5 && colour_table.ends_with(".yaml"));
  if (!isPath) return colour_table;
  const fs::path folder = fs::absolute(fs::path(out_path)).parent_path();
  return fs::absolute(fs::path(colour_table))
      .lexically_normal()
      .lexically_relative(folder)
      .string();
}

std::vector<std::string> mirrorProblems(const camera::MirrorParams& m, double min_reach) {
  std::vector<std::string> out;
  if (m.axis_offset.norm() > 0.25) {
    out.push_back(fmt::format("axis offset ({:.3f}, {:.3f}) m is beyond 0.25 m: not a robot's",
                              m.axis_offset.x(), m.axis_offset.y()));
  }
  const auto* t = std::get_if<camera::CalibrationTableParams>(&m.distance.params());
  if (t == nullptr) return out;
  for (std::size_t i = 1; i < t->radii.size(); ++i) {
    if (t->radii[i] - t->radii[i - 1] < 0.5) {
      out.push_back(fmt::format("knots at {:.3f} and {:.3f} px are less than half a pixel apart",
                                t->radii[i - 1], t->radii[i]));
      break;
    }
  }
  for (std::size_t s = 0; s < t->distances.size(); ++s) {
    const std::vector<double>& d = t->distances[s];
    const double bearing = t->sector_bearings[s] * 180.0 / std::numbers::pi;
    double lastSlope = d[0] / t->radii[0];
    for (std::size_t i = 1; i < d.size(); ++i) {
      const double slope = (d[i] - d[i - 1]) / (t->radii[i] - t->radii[i - 1]);
      if (!(slope > 1e-5)) {
        out.push_back(
            fmt::format("sector {:.0f}°: distances do not increase between {:.1f} and {:.1f} px",
                        bearing, t->radii[i - 1], t->radii[i]));
        break;
      }
      if (slope < 0.5 * lastSlope || slope > 4.0 * lastSlope) {
        out.push_back(fmt::format(
            "sector {:.0f}°: a kink at {:.1f} px (metres per pixel {:.4f} after {:.4f})", bearing,
            t->radii[i - 1], slope, lastSlope));
        break;
      }
      lastSlope = slope;
    }
    if (d.back() < min_reach) {
      out.push_back(
          fmt::format("sector {:.0f}°: the table reaches only {:.2f} m (at least {:g} "
                      "m expected)",
                      bearing, d.back(), min_reach));
    }
  }
  return out;
}

void MirrorCalibrateOptions::addTo(cli::App& app) {
  auto* in = app.add_option("--rings", rings, "Image of the ring carpet (PNG, JPEG, BMP)");
  app.add_flag("--render-rings", render_rings,
               "Calibrate from a rendered ring carpet (the camera's mirror, moved by "
               "--render-centre-shift and --render-offset, with --realism)")
      ->excludes(in);
  app.add_option("--lines", lines,
                 "A frame of the field on its own (repeatable); the pose is searched unless "
                 "--pose gives one per --lines frame")
      ->excludes(in);
  app.add_option("--spot", spots,
                 "Frames taken at one spot while the robot turned on it, comma-separated "
                 "(repeatable: one --spot per spot); they share one position, which pins the "
                 "axis offset")
      ->excludes(in);
  app.add_option("--pose", poses,
                 "The robot's field pose x,y,phi of each --lines frame, when known (optional)");
  app.add_flag("--render-lines", render_lines,
               "Calibrate from rendered field frames at the --pose poses (default four poses)");
  app.add_option("--venue", venue,
                 "Calibrate from the frames of a rendered venue case (tests/data/venue_cases/"
                 "*.yaml), its spots as --spot, and compare with its true mirror and poses");
  app.add_option("--field", field, "Field preset or file the frames show")->capture_default_str();
  app.add_option("--distances", distances,
                 "Ring distances from the robot's centre: 1,1.5,2 (m) or a file with "
                 "`distN = <mm>` lines (default for --render-rings: the rendered carpet's)");
  app.add_option("--camera", camera,
                 "Base camera preset (name or path): heading, mirror sense, radii (scaled to the "
                 "frames' size); its mirror is only where the search starts")
      ->capture_default_str();
  app.add_option("--min-radius", min_radius,
                 "Search rings from this radius, px (0: the base camera's reflection, scaled)");
  app.add_option("--max-radius", max_radius,
                 "Search rings up to this radius, px (0: the mirror's rim, or the image's edge)");
  app.add_option("--min-contrast", min_contrast, "Grey levels a ring stands above the floor")
      ->capture_default_str();
  app.add_option("--sectors", sectors, "Bearing sectors of the table")->capture_default_str();
  app.add_option("--radius-step", radius_step, "Table radii spacing, px")->capture_default_str();
  app.add_option("--offset", offset,
                 "The mirror axis' offset from the robot's centre: auto (fitted where the data "
                 "pins it), fit (refuse when it does not), zero")
      ->check(cli::IsMember({"auto", "fit", "zero"}))
      ->capture_default_str();
  app.add_flag("--no-offset", no_offset, "Same as --offset zero");
  app.add_option("--render-centre-shift", render_centre_shift, "du,dv px")->capture_default_str();
  app.add_option("--render-offset", render_offset, "x,y m")->capture_default_str();
  app.add_option("--realism", realism, "Realism setting of the rendered carpet")
      ->capture_default_str();
  app.add_option("--out", out,
                 "Write the camera YAML here (only when the calibration passes its checks)");
  app.add_option("--debug-png", debug_png, "Write the rings found and the fitted table here");
  app.add_flag("--verbose", verbose,
               "Print the search's candidate mirrors, each frame's candidate poses and every "
               "round of the joint fit (frames of the field)");
}

namespace {

OffsetMode offsetMode(const MirrorCalibrateOptions& o) {
  if (o.no_offset || o.offset == "zero") return OffsetMode::kZero;
  return o.offset == "fit" ? OffsetMode::kFit : OffsetMode::kAuto;
}

// The frames of the field to calibrate from (--venue, --render-lines, or --lines/--spot files),
// with the truth where they were rendered.
struct LineFrames {
  field::FieldModel field;
  std::vector<UnposedFrame> frames;
  std::optional<camera::MirrorModel> truth;
  std::vector<geometry::Pose2> true_poses;
};

LineFrames gatherLineFrames(const MirrorCalibrateOptions& o, const camera::CameraConfig& config) {
  const camera::MirrorParams base = config.model.mirror.params();
  LineFrames out{field::loadFieldPreset(o.field), {}, std::nullopt, {}};
  field::FieldModel& field = out.field;
  std::vector<UnposedFrame>& frames = out.frames;
  std::optional<camera::MirrorModel>& truth = out.truth;
  std::vector<geometry::Pose2>& truePoses = out.true_poses;
  if (!o.venue.empty()) {
    const venue::RenderedVenue v = venue::renderVenue(venue::loadVenueCase(o.venue));
    field = v.field;
    truth.emplace(v.mirror);
    for (std::size_t i = 0; i < v.frames.size(); ++i) {
      frames.push_back({greyFromFrame(v.view(i)), v.frames[i].spot, std::nullopt,
                        fmt::format("frame_{:02d}", i), yuvPlane(v.view(i))});
      truePoses.push_back(v.frames[i].pose);
    }
  } else if (o.render_lines) {
    std::vector<geometry::Pose2> poses;
    for (const std::string& p : o.poses)
      poses.push_back(parsePose(p));
    if (poses.empty())
      poses = {{-6.0, 1.5, 0.4}, {0.5, 0.8, 0.3}, {-3.5, -2.5, 2.0}, {4.0, 3.0, -1.0}};
    camera::MirrorParams t = base;
    const std::vector<double> shift = numbers(o.render_centre_shift, 2, "--render-centre-shift");
    const std::vector<double> offset = numbers(o.render_offset, 2, "--render-offset");
    t.centre += Vec2(shift[0], shift[1]);
    t.axis_offset = Vec2(offset[0], offset[1]);
    truth.emplace(t);
    const std::vector<PosedImage> rendered =
        renderFieldFrames(*truth, field, camera::renderParamsOf(config, "--render-lines"), poses,
                          realismSetting(o.realism).realism);
    for (std::size_t i = 0; i < rendered.size(); ++i) {
      frames.push_back({rendered[i].image, -1, rendered[i].pose, fmt::format("render_{}", i), {}});
      truePoses.push_back(rendered[i].pose);
    }
  } else {
    if (!o.poses.empty() && o.poses.size() != o.lines.size()) {
      throw std::invalid_argument(fmt::format(
          "{} --lines frames but {} --pose values (give none, or one per --lines frame)",
          o.lines.size(), o.poses.size()));
    }
    for (std::size_t i = 0; i < o.lines.size(); ++i) {
      std::optional<geometry::Pose2> pose;
      if (!o.poses.empty()) pose = parsePose(o.poses[i]);
      const cv::Mat bgr = camera::readBgrImage(o.lines[i]);
      frames.push_back({greyFromMat(bgr), -1, pose, o.lines[i], yuvPlane(camera::viewOfBgr(bgr))});
    }
    for (std::size_t s = 0; s < o.spots.size(); ++s) {
      const std::vector<std::string> files = splitList(o.spots[s]);
      if (files.empty()) throw std::invalid_argument("--spot: no frames in '" + o.spots[s] + "'");
      for (const std::string& f : files) {
        const cv::Mat bgr = camera::readBgrImage(f);
        frames.push_back({greyFromMat(bgr), static_cast<int>(s), std::nullopt, f,
                          yuvPlane(camera::viewOfBgr(bgr))});
      }
    }
  }
  return out;
}

// Frames of the field: --lines, --spot, --render-lines or --venue.
int runLines(const MirrorCalibrateOptions& o, const camera::CameraConfig& config) {
  const camera::MirrorParams base = config.model.mirror.params();
  LineFrames input = gatherLineFrames(o, config);
  const field::FieldModel& field = input.field;
  const std::vector<UnposedFrame>& frames = input.frames;
  const std::optional<camera::MirrorModel>& truth = input.truth;
  const std::vector<geometry::Pose2>& truePoses = input.true_poses;
  PoseFreeParams params;
  params.sectors = o.sectors;
  params.radius_step = o.radius_step;
  params.offset = offsetMode(o);
  params.verbose = o.verbose;
  const PoseFreeCalibration c = calibrateAtUnknownPose(frames, field, base, params);
  printPoseFreeReport(c);
  if (truth) {
    const MirrorError e = compareMirrors(*truth, camera::MirrorModel(c.mirror), 5.0);
    const MirrorError e1 = compareMirrors(*truth, camera::MirrorModel(c.mirror), 5.0, 1.0);
    double worst = 0.0;
    for (std::size_t i = 0; i < c.frames.size(); ++i) {
      const geometry::Pose2& t = truePoses[i];
      const double a = (c.frames[i].pose.position() - t.position()).norm();
      const double b = (c.frames[i].twin.position() - t.position()).norm();
      worst = std::max(worst, std::min(a, b));
    }
    fmt::print(
        "against the rendered truth: centre {:.2f} px, axis offset {:.1f} cm, distance "
        "function 1-5 m {:.2f} % (up to 5 m {:.2f} %), floor points up to 5 m {:.1f} cm, "
        "poses (or their twins) within {:.1f} cm\n",
        e.centre_px, 100 * e.offset_m, e1.distance_percent, e.distance_percent,
        100 * e.floor_point_m, 100 * worst);
  }
  // The quality a useful calibration has; below it nothing is written.
  const std::vector<std::string> weak = weaknesses(c, field.name());
  if (!weak.empty()) {
    std::string why;
    for (const std::string& w : weak)
      why += "\n  " + w;
    throw Refusal("the calibration is not good enough to write:" + why);
  }
  if (!o.out.empty()) {
    std::string poses;
    for (const FramePose& f : c.frames)
      poses +=
          fmt::format("\n  {}: {:.3f}, {:.3f}, {:.4f}", f.name, f.pose.x, f.pose.y, f.pose.phi);
    return writePreset(
        o, config, c.mirror, 3.0,
        fmt::format("Written by fieldline-mirror-calibrate from {} field frame(s), poses "
                    "searched (base preset {}).\nResiduals: rms {:.2f} px, {:.1f} cm to the "
                    "lines; axis offset {}.\nPoses found (x, y, phi; or their twins):{}",
                    frames.size(), o.camera, c.rms_px, c.rms_cm, c.offset_note, poses));
  }
  return 0;
}

// Prints each ring's check (checkRings); returns the worst sector's miss, %.
double printRingChecks(const RingCalibration& c, int sectors) {
  const std::vector<RingCheck> rings = checkRings(c, sectors);
  fmt::print("{:>9s} {:>7s} {:>13s} {:>15s} {:>14s}\n", "ring (m)", "points", "median err %",
             "worst sector %", "held out %");
  double worst = 0.0;
  for (const RingCheck& r : rings) {
    fmt::print("{:9g} {:7d} {:13.2f} {:15.2f} {:>14s}\n", r.distance, r.points, r.median_percent,
               r.worst_sector_percent,
               std::isfinite(r.held_out_percent) ? fmt::format("{:.2f}", r.held_out_percent)
                                                 : std::string("-"));
    worst = std::max(worst, r.worst_sector_percent);
  }
  fmt::print(
      "(held out: the ring's distance read from the curve through the other rings, the "
      "outermost excepted)\n");
  return worst;
}

}  // namespace

int runMirrorCalibrate(const MirrorCalibrateOptions& o) {
  const int inputs = (o.rings.empty() ? 0 : 1) + (o.render_rings ? 1 : 0) +
                     (o.lines.empty() && o.spots.empty() ? 0 : 1) + (o.render_lines ? 1 : 0) +
                     (o.venue.empty() ? 0 : 1);
  if (inputs != 1) {
    throw std::invalid_argument(
        "give one of --rings IMAGE, --render-rings, --lines/--spot FRAMES, --render-lines, "
        "--venue CASE");
  }
  const camera::CameraConfig config = camera::loadCameraConfigPreset(o.camera);
  if (!o.lines.empty() || !o.spots.empty() || o.render_lines || !o.venue.empty()) {
    return runLines(o, config);
  }
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
    base = ringBaseFor(image, base, o.min_radius, o.max_radius);
  }
  RingCalibrationParams params;
  params.search.min_radius = o.min_radius > 0.0 ? o.min_radius : base.self_radius;
  params.search.max_radius = o.max_radius > 0.0 ? o.max_radius : base.outer_radius;
  params.search.min_contrast = o.min_contrast;
  params.sectors = o.sectors;
  params.radius_step = o.radius_step;
  params.fit.fit_offset = offsetMode(o) != OffsetMode::kZero;
  const RingCalibration c = calibrateFromRings(image, distances, base, params);
  printReport(c);
  const double worstRing = printRingChecks(c, o.sectors);
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
  if (worstRing > 3.0) {
    throw Refusal(fmt::format(
        "the table misses a ring by {:.1f} % in a sector (at most 3 %): rings mismatched or a "
        "strut taken for a ring; check --debug-png",
        worstRing));
  }
  if (!o.out.empty()) {
    return writePreset(
        o, config, c.mirror, c.distances.back() * 0.9,
        fmt::format("Written by fieldline-mirror-calibrate from {} (base preset {}).\n"
                    "Residuals of the table: rms {:.2f} px, {:.2f} % of the distance, max "
                    "{:.2f} %.",
                    o.render_rings ? "a rendered ring carpet" : o.rings, o.camera,
                    c.table.total.rms_px, c.table.total.rms_percent, c.table.total.max_percent));
  }
  return 0;
}

}  // namespace fieldline::calibration
