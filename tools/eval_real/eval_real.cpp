#include "tools/eval_real/eval_real.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include <fmt/core.h>

#include "common/camera/image_io.hpp"
#include "common/config/config.hpp"
#include "common/config/paths.hpp"
#include "common/field/field_model.hpp"
#include "services/camera/camera_config.hpp"
#include "services/fusion/line_matcher.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/calibration_common/floor_colour.hpp"
#include "tools/calibration_common/percentile.hpp"
#include "tools/calibration_common/staged_output.hpp"
#include "tools/colour_calibrate/colour_calibration.hpp"
#include "tools/colour_calibrate/evaluation.hpp"
#include "tools/colour_calibrate/image_calibration.hpp"
#include "tools/eval_real/venue_cases.hpp"
#include "tools/mirror_calibrate/app.hpp"
#include "tools/mirror_calibrate/evaluation.hpp"
#include "tools/mirror_calibrate/pose_free.hpp"

namespace fieldline::evalreal {
namespace {

namespace fs = std::filesystem;
namespace cal = fieldline::calibration;
using geometry::Pose2;
using geometry::Vec2;

// A case whose input is not on this machine (real data kept elsewhere) is skipped: nothing
// measured, nothing judged.
bool skippedWithout(const std::string& input, CaseResult& r) {
  if (fs::exists(input)) return false;
  r.skipped = true;
  r.figures = "skipped: " + input + " is not there";
  return true;
}

std::map<std::string, double> expectations(const config::Node& root) {
  std::map<std::string, double> out;
  if (const std::optional<config::Node> e = root.childIf("expect")) {
    for (const std::string& key : e->keys())
      out[key] = e->get<double>(key);
  }
  return out;
}

// A bound checked: `at_most` or at least; the failure names the figure.
void bound(CaseResult& r, const std::map<std::string, double>& expect, const std::string& key,
           double value, bool at_most) {
  const auto it = expect.find(key);
  if (it == expect.end()) return;
  const bool ok = std::isfinite(value) && (at_most ? value <= it->second : value >= it->second);
  if (!ok) {
    r.failed.push_back(
        fmt::format("{} {:.3g} {} {:.3g}", key, value, at_most ? ">" : "<", it->second));
  }
}

std::vector<Vec2> readPoints(const std::string& path, double scale) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::vector<Vec2> out;
  int lineNo = 0;
  for (std::string line; std::getline(in, line);) {
    ++lineNo;
    std::istringstream row(line);
    double x = 0.0, y = 0.0;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[0] == '#') continue;
    if (!(row >> x >> y) || !std::isfinite(x) || !std::isfinite(y)) {
      throw std::runtime_error(fmt::format("{}:{}: expected two numbers", path, lineNo));
    }
    out.emplace_back(x * scale, y * scale);
  }
  return out;
}

double scaleOf(const config::Node& root) {
  const std::string unit = root.has("unit") ? root.getChoice("unit", {"mm", "m"}) : "m";
  return unit == "mm" ? 0.001 : 1.0;
}

void runRings(const config::Node& root, CaseResult& r) {
  const std::string image = config::resolveAgainst(root.file(), "", root.get<std::string>("image"));
  // A list of metres, or a file beside the manifest (CarpetCalibrator.conf's `distN = mm`).
  std::vector<double> listed;
  std::string distancesFile;
  if (root.yaml()["distances"] && root.yaml()["distances"].IsSequence()) {
    listed = root.getList<double>("distances");
  } else {
    distancesFile = config::resolveAgainst(root.file(), "", root.get<std::string>("distances"));
  }
  const std::string camera =
      config::resolveAgainst(root.file(), "camera", root.getOr<std::string>("camera", "omni_sim"));
  const auto expect = expectations(root);
  (void)root.getOr<std::string>("known", "");
  root.rejectUnknownKeys();
  if (skippedWithout(image, r)) return;
  std::vector<double> distances = listed;
  if (distances.empty()) {
    if (!fs::exists(distancesFile)) root.fail("distances", distancesFile + " is not there");
    distances = cal::parseDistances(distancesFile);
  }
  const cv::Mat bgr = camera::readBgrImage(image);
  cal::GreyImage grey = cal::greyFromFrame(camera::viewOfBgr(bgr));
  const camera::MirrorParams base =
      cal::ringBaseFor(grey, camera::loadCameraPreset(camera).mirror.params(), 0.0, 0.0);
  cal::RingCalibrationParams params;
  params.search.min_radius = base.self_radius;
  params.search.max_radius = base.outer_radius;
  try {
    const cal::RingCalibration c = cal::calibrateFromRings(grey, distances, base, params);
    double worst = 0.0, heldOut = 0.0;
    const std::vector<cal::RingCheck> rings = cal::checkRings(c, params.sectors);
    for (std::size_t k = 0; k < rings.size(); ++k) {
      worst = std::max(worst, rings[k].worst_sector_percent);
      // Inner rings only: the first ring held out is read between the origin and the second.
      if (k > 0 && std::isfinite(rings[k].held_out_percent)) {
        heldOut = std::max(heldOut, rings[k].held_out_percent);
      }
    }
    r.figures = fmt::format(
        "{} rings found, {} matched to {:g}-{:g} m (ring {} = {:g} m), centre ({:.1f}, {:.1f}) "
        "px, table rms {:.2f} px; rings' distances: worst sector {:.2f} %, inner ring held out "
        "{:.2f} %",
        c.found_radii.size(), c.match.count, c.distances.front(), c.distances.back(),
        c.match.first_ring + 1, c.distances.front(), c.fit.centre.x(), c.fit.centre.y(),
        c.table.total.rms_px, worst, heldOut);
    bound(r, expect, "max_ring_error_percent", worst, true);
    bound(r, expect, "max_held_out_percent", heldOut, true);
    bound(r, expect, "rings", c.match.count, false);
  } catch (const std::exception& e) {
    r.figures = std::string("refused: ") + e.what();
    r.failed.push_back("the rings were not calibrated");
  }
}

// A pose layer 2 found for the points on a candidate field, and how well they fit there.
struct Fit {
  std::string field;
  Pose2 pose;
  double on = 0.0, median_cm = 0.0;
};

// Layer 2's global search on every candidate field; the fields whose presets are not there go to
// `missing`.
std::vector<Fit> fitFields(const std::vector<std::string>& fields,
                           const perception::LinePoints& lines, const std::vector<Vec2>& pts,
                           std::vector<std::string>& missing) {
  std::vector<Fit> fits;
  for (const std::string& name : fields) {
    std::optional<field::FieldModel> model;
    try {
      model.emplace(field::loadFieldPreset(name));
    } catch (const config::Error&) {
      if (fs::exists(name)) throw;  // there but broken: the manifest's error, exit 2
      missing.push_back(fs::path(name).stem().string());
      continue;
    }
    const fusion::LineMatcher matcher(*model, fusion::withCalibratedCamera({}));
    for (const fusion::PoseCorrection& c : matcher.globalSearch(lines.points)) {
      std::vector<double> d;
      int near = 0;
      for (const Vec2& p : pts) {
        const double e = model->distance(geometry::pointRobotToField(c.pose, p));
        d.push_back(e);
        near += e <= 0.15 ? 1 : 0;
      }
      fits.push_back({model->name(), c.pose, static_cast<double>(near) / pts.size(),
                      100.0 * cal::upperMedian(d)});
    }
  }
  return fits;
}

// The runner-up: the best answer elsewhere (not the same pose nor its twin) on any field.
const Fit* runnerUp(const std::vector<Fit>& fits) {
  const Fit& best = fits.front();
  const Fit* second = nullptr;
  for (const Fit& f : fits) {
    const Vec2 p = f.pose.position();
    if (f.field == best.field &&
        ((p - best.pose.position()).norm() < 0.5 || (p + best.pose.position()).norm() < 0.5)) {
      continue;
    }
    second = &f;
    break;
  }
  return second;
}

void runLinePoints(const config::Node& root, CaseResult& r) {
  const std::string file = config::resolveAgainst(root.file(), "", root.get<std::string>("points"));
  const double scale = scaleOf(root);
  std::vector<std::string> fields;
  for (const config::Node& f : root.children("fields"))
    fields.push_back(config::resolveAgainst(root.file(), "field", f.as<std::string>()));
  const auto expect = expectations(root);
  (void)root.getOr<std::string>("known", "");
  root.rejectUnknownKeys();
  if (skippedWithout(file, r)) return;
  const std::vector<Vec2> pts = readPoints(file, scale);
  perception::LinePoints lines;
  for (const Vec2& p : pts) {
    perception::LinePoint lp;
    lp.x = static_cast<float>(p.x());
    lp.y = static_cast<float>(p.y());
    lines.points.push_back(lp);
  }
  std::vector<std::string> missing;
  std::vector<Fit> fits = fitFields(fields, lines, pts, missing);
  std::sort(fits.begin(), fits.end(), [](const Fit& a, const Fit& b) { return a.on > b.on; });
  if (fits.empty()) {
    r.figures = fmt::format("{} points: no field fits{}", pts.size(),
                            missing.empty() ? "" : " (missing field presets)");
    if (missing.size() == fields.size()) {
      r.skipped = true;  // no candidate field is there: nothing was measured
    } else if (expect.count("no_fit") && expect.at("no_fit") > 0) {
      // Points layer 2 must refuse (its `valid`: a bounded cost, half the points near a line).
      r.figures += ": layer 2 refuses them on every candidate field, as expected";
    } else {
      r.failed.push_back("no field fits the points");
    }
    return;
  }
  if (expect.count("no_fit") && expect.at("no_fit") > 0) {
    r.failed.push_back("no_fit: layer 2 accepted points it is expected to refuse");
  }
  const Fit& best = fits.front();
  const Fit* second = runnerUp(fits);
  r.figures = fmt::format(
      "{} points (up to {:.1f} m): best field {}, pose ({:.2f}, {:.2f}, {:.1f} deg), {:.0f} % "
      "within 15 cm, median {:.1f} cm; runner-up {}",
      pts.size(),
      std::max_element(pts.begin(), pts.end(),
                       [](const Vec2& a, const Vec2& b) { return a.norm() < b.norm(); })
          ->norm(),
      best.field, best.pose.x, best.pose.y, best.pose.phi * 180.0 / std::numbers::pi, 100 * best.on,
      best.median_cm,
      second ? fmt::format("{} ({:.2f}, {:.2f}, {:.1f} deg) {:.0f} %", second->field,
                           second->pose.x, second->pose.y,
                           second->pose.phi * 180.0 / std::numbers::pi, 100 * second->on)
             : std::string("none"));
  if (!missing.empty()) {
    // A candidate field is not there (its preset is not on this branch): the best field may be
    // the missing one, so the figures are printed but nothing is judged.
    std::string list;
    for (const std::string& m : missing)
      list += (list.empty() ? "" : ", ") + m;
    r.figures += " (not judged: field presets not found: " + list + ")";
    r.skipped = true;
    return;
  }
  bound(r, expect, "min_on_lines", best.on, false);
}

void runFieldPoints(const config::Node& root, CaseResult& r) {
  const std::string file = config::resolveAgainst(root.file(), "", root.get<std::string>("points"));
  const double scale = scaleOf(root);
  const std::string fieldName =
      config::resolveAgainst(root.file(), "field", root.get<std::string>("field"));
  const auto expect = expectations(root);
  (void)root.getOr<std::string>("known", "");
  root.rejectUnknownKeys();
  if (skippedWithout(file, r)) return;
  std::optional<field::FieldModel> model;
  try {
    model.emplace(field::loadFieldPreset(fieldName));
  } catch (const config::Error& e) {
    // A preset that is not there (not on this branch): nothing measured, nothing judged. One
    // that is there but does not load is a failure.
    r.figures = std::string(fs::exists(fieldName) ? "field not loaded: " : "skipped: ") + e.what();
    if (fs::exists(fieldName)) {
      r.failed.push_back("the field preset does not load");
    } else {
      r.skipped = true;
    }
    return;
  }
  const std::vector<Vec2> pts = readPoints(file, scale);
  std::vector<double> d;
  int near = 0;
  for (const Vec2& p : pts) {
    d.push_back(model->distance(p));
    near += d.back() <= 0.10 ? 1 : 0;
  }
  r.figures = fmt::format(
      "{} points in the field frame against field {}: median {:.1f} cm from "
      "its lines, {:.0f} % within 10 cm",
      pts.size(), model->name(), 100 * cal::upperMedian(d),
      100.0 * near / std::max<std::size_t>(1, pts.size()));
  bound(r, expect, "max_median_cm", 100 * cal::upperMedian(d), true);
}

// The ball detector of region tracking on a venue's frames, with the calibrated mirror and colour
// table, and the ball region at the pose the mirror calibration solved for each frame (as fusion's
// pose would give it: the field check of issue 30 item 6). Judged against the truth: a frame
// where the ball is imaged inside the useful zone counts as found when the detection lies within
// `found_within_m` of the true ball; a detection anywhere off the field (true pose) is an
// outside ball; any other detection, or one in a frame without the ball, a false ball.
struct BallFigures {
  int visible = 0;
  int found = 0;
  int outside = 0;
  int false_balls = 0;
  double foundShare() const { return visible > 0 ? static_cast<double>(found) / visible : 0.0; }
};

BallFigures detectBalls(const venue::RenderedVenue& v, const camera::MirrorModel& mirror,
                        const camera::ColourTable& table,
                        const std::vector<geometry::Pose2>& solved_poses, const Vec2& ball,
                        double found_within_m = 0.5) {
  BallFigures f;
  for (std::size_t i = 0; i < v.frames.size(); ++i) {
    region_tracking::FrameProcessor processor(mirror, table,
                                              region_tracking::defaultVisionParams());
    processor.setBallRegion(region_tracking::BallRegion{&v.field, solved_poses[i], 0.1});
    region_tracking::VisionResult result;
    // As trackLines: the tracker settles over a few passes of the same frame.
    for (int pass = 0; pass < 3; ++pass)
      processor.process(v.view(i), false, result);
    const bool in_view = v.frames[i].ball_pixel.has_value();
    f.visible += in_view ? 1 : 0;
    if (!result.ball.visible) continue;
    const Vec2 seen =
        geometry::pointRobotToField(v.frames[i].pose, Vec2(result.ball.x, result.ball.y));
    if (!v.field.insideLines(seen)) {
      ++f.outside;
    } else if (in_view && (seen - ball).norm() <= found_within_m) {
      ++f.found;
    } else {
      ++f.false_balls;
    }
  }
  return f;
}

// 1. The mirror, from the shipped camera preset and no pose; nullopt (the case failed) when the
// calibration refused.
std::optional<cal::PoseFreeCalibration> venueMirror(const venue::VenueCase& spec,
                                                    const venue::RenderedVenue& v,
                                                    const std::vector<cal::UnposedFrame>& frames,
                                                    CaseResult& r) {
  std::optional<cal::PoseFreeCalibration> mirror;
  try {
    mirror = cal::calibrateAtUnknownPose(frames, v.field,
                                         camera::loadCameraPreset(spec.camera).mirror.params(), {});
  } catch (const cal::Refusal& e) {
    r.figures = std::string("mirror refused: ") + e.what();
    r.failed.push_back("the mirror calibration refused");
    return std::nullopt;
  }
  return mirror;
}

// The fitted mirror against the true one: distances, poses, offset, and whether the tool would
// write it.
void judgeMirror(const venue::VenueCase& spec, const venue::RenderedVenue& v,
                 const cal::PoseFreeCalibration& mirror, const camera::MirrorModel& fitted,
                 CaseResult& r) {
  const std::vector<std::string> weak = cal::weaknesses(mirror, v.field.name());
  const cal::MirrorError e = cal::compareMirrors(v.mirror, fitted, 5.0, 1.0);
  double poseCm = 0.0;
  for (std::size_t i = 0; i < v.frames.size(); ++i) {
    const Vec2 t = v.frames[i].pose.position();
    poseCm = std::max(poseCm, 100.0 * std::min((mirror.frames[i].pose.position() - t).norm(),
                                               (mirror.frames[i].twin.position() - t).norm()));
  }
  r.figures = fmt::format(
      "mirror: distance 1-5 m {:.2f} %, poses {:.1f} cm, offset {:.1f} cm{}{}", e.distance_percent,
      poseCm, 100 * e.offset_m,
      mirror.search.non_finite_points > 0
          ? fmt::format(" ({} refusals of non-finite points)", mirror.search.non_finite_points)
          : std::string(),
      weak.empty() ? "" : " (would refuse: " + weak.front() + ")");
  bound(r, spec.expect, "max_distance_percent", e.distance_percent, true);
  bound(r, spec.expect, "max_pose_cm", poseCm, true);
  bound(r, spec.expect, "max_offset_cm", 100 * e.offset_m, true);
  if (!weak.empty()) r.failed.push_back("the mirror calibration would refuse to write");
}

// The ball: the detector with the calibrated mirror and table, and the ball class's place.
struct BallVerdict {
  std::string ball = "no ball in the case";
  std::string ball_detector;
  bool ball_right = false;
};

BallVerdict judgeBall(const venue::VenueCase& spec, const venue::RenderedVenue& v,
                      const cal::PoseFreeCalibration& mirror, const camera::MirrorModel& fitted,
                      const cal::FramesCalibration& colours, CaseResult& r) {
  BallVerdict verdict;
  if (spec.ball) {
    std::vector<geometry::Pose2> solved;
    for (std::size_t i = 0; i < v.frames.size(); ++i)
      solved.push_back(mirror.frames[i].pose);
    const BallFigures b = detectBalls(v, fitted, colours.calibration.table, solved, *spec.ball);
    verdict.ball_detector = fmt::format(
        "; ball detector: found in {} of {} frames where it is in view, {} outside the field, {} "
        "false",
        b.found, b.visible, b.outside, b.false_balls);
    if (b.visible > 0) bound(r, spec.expect, "min_ball_found", b.foundShare(), false);
    bound(r, spec.expect, "max_balls_outside", b.outside, true);
    const cal::ImageCalibration& c = colours.calibration;
    const double off = c.ball_found ? std::min((c.ball_field - *spec.ball).norm(),
                                               (c.ball_field + *spec.ball).norm())
                                    : 1e9;
    verdict.ball_right = c.ball_found && off < 0.3;
    verdict.ball = c.ball_found
                       ? fmt::format("ball class from the ball {:.2f} m off its place", off)
                       : "no ball class";
  }
  return verdict;
}

void runVenue(const std::string& manifest, CaseResult& r) {
  const venue::VenueCase spec = venue::loadVenueCase(manifest);
  r.name = spec.name;
  const venue::RenderedVenue v = venue::renderVenue(spec);
  std::vector<cal::UnposedFrame> frames;
  std::vector<camera::FrameView> views;
  for (std::size_t i = 0; i < v.frames.size(); ++i) {
    frames.push_back({cal::greyFromFrame(v.view(i)), v.frames[i].spot, std::nullopt,
                      fmt::format("frame_{:02d}", i), cal::yuvPlane(v.view(i))});
    views.push_back(v.view(i));
  }
  // 1. The mirror, from the shipped camera preset and no pose.
  const std::optional<cal::PoseFreeCalibration> mirror = venueMirror(spec, v, frames, r);
  if (!mirror) return;
  const camera::MirrorModel fitted(mirror->mirror);
  judgeMirror(spec, v, *mirror, fitted, r);
  // 2. The colours, with that mirror, from the frames alone.
  std::optional<cal::FramesCalibration> colours;
  try {
    colours = cal::calibrateColours(fitted, v.field, views, cal::ImageFitParams{});
  } catch (const cal::Refusal& x) {
    r.figures += std::string("; colour refused: ") + x.what();
    r.failed.push_back("the colour calibration refused");
    return;
  }
  // 3. Line points with both, scored against the truth (the true mirror and poses).
  cal::ScoreSum score;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const perception::LinePoints lines =
        cal::trackLines(fitted, colours->calibration.table, views[i]);
    score.add(cal::scoreLinePoints(v.mirror, v.field, v.frames[i].pose, lines, {}));
  }
  const BallVerdict b = judgeBall(spec, v, *mirror, fitted, *colours, r);
  r.figures += fmt::format(
      "; colours: {} line points, precision {:.3f}, recall {:.3f} (worst frame {:.3f}), {}{}{}",
      score.points, score.precision(), score.recall(), score.min_recall, b.ball,
      colours->check.problems.empty() ? "" : " (check would refuse)", b.ball_detector);
  bound(r, spec.expect, "min_precision", score.precision(), false);
  bound(r, spec.expect, "min_recall", score.recall(), false);
  if (spec.expect.count("ball") && spec.expect.at("ball") > 0 && !b.ball_right) {
    r.failed.push_back("ball: no ball class from the ball");
  }
  if (!colours->check.problems.empty()) {
    r.failed.push_back("the colour calibration's check would refuse: " +
                       colours->check.problems.front());
  }
}

}  // namespace

std::vector<std::string> manifestsIn(const std::string& folder) {
  std::vector<std::string> out;
  if (!fs::is_directory(folder)) return out;
  for (const auto& entry : fs::directory_iterator(folder)) {
    // Canonical: a manifest's relative paths then pass a symlinked folder (build/share/fieldline
    // links into the source tree) the way the file system does.
    if (entry.path().extension() == ".yaml") out.push_back(fs::canonical(entry.path()).string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

CaseResult runCase(const std::string& manifest) {
  const auto start = std::chrono::steady_clock::now();
  CaseResult r;
  const config::Node root = config::Node::loadFile(manifest);
  r.name = fs::path(manifest).stem().string();
  try {
    if (root.has("spots")) {
      r.kind = "venue";
      runVenue(manifest, r);
    } else {
      r.kind = root.getChoice("kind", {"rings", "line_points", "field_points"});
      r.name = root.getOr<std::string>("name", r.name);
      if (r.kind == "rings") runRings(root, r);
      if (r.kind == "line_points") runLinePoints(root, r);
      if (r.kind == "field_points") runFieldPoints(root, r);
    }
  } catch (const config::Error&) {
    throw;  // the manifest's error: the run stops with exit 2
  } catch (const std::exception& e) {
    // Anything else a tool or the case's data throws is this case's failure, with its reason;
    // the other cases still run.
    r.figures += std::string(r.figures.empty() ? "" : "; ") + "stopped: " + e.what();
    r.failed.push_back(std::string("the case ran to its end (it stopped: ") + e.what() + ")");
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace fieldline::evalreal
