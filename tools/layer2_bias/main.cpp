// fieldline-layer2-bias: where layer 2 (services/fusion/line_matcher) is biased on rendered frames.
// Renders still frames (no motion blur; sensor noise as the preset's unless --no-noise) with the
// simulated camera, tracks them with the region tracker as the node does (lines on every frame),
// and matches the line points with layer 2 from the true pose (and optionally from an offset).
//
//   --map            a grid of poses over the field: one row per pose with layer 2's error
//   --pose x,y,phi   one pose in detail: every line point's signed distance to the line it belongs
//                    to (field frame, the normal's sign), grouped by line element and by range
//
// Output is CSV on stdout (comment lines start with #). A tool for analysis, not part of a node.
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "services/fusion/line_matcher.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace cli = fieldline::cli;

namespace {

using fieldline::geometry::Pose2;
using fieldline::geometry::Vec2;
using fieldline::perception::LinePoint;
namespace fusion = fieldline::fusion;
namespace rt = fieldline::region_tracking;
namespace camera = fieldline::camera;
namespace field = fieldline::field;

struct Options {
  std::string camera = "omni_sim";
  std::string field = "msl";
  bool no_noise = false;
  int frames = 3;
  double offset_m = 0.0;
  double step_m = 1.0;
  int headings = 4;
  std::string pose;
  bool map = false;
  bool points = false;
  double max_range = -1.0;
  // Model points instead of rendered ones: the lines' centres within `synthetic_range` of the
  // robot, every 2 cm, with Gaussian scatter across and along (m); isolates the matcher.
  bool synthetic = false;
  double synthetic_range = 4.0;
  double synthetic_sigma = 0.0;
  std::uint32_t seed = 1;
  std::string grid_cache = fieldline::config::defaultCacheDirectory();
};

rt::SimCamera loadCamera(const Options& o) {
  const fieldline::config::Node root =
      fieldline::config::Node::loadFile(fieldline::config::resolvePreset("camera", o.camera));
  camera::CameraModel model = camera::loadCameraModel(root);
  field::FieldModel f = field::loadFieldPreset(o.field);
  camera::ColourTable table = camera::loadColourTablePreset(model.colour_table);
  camera::RenderParams render = camera::loadRenderParams(root.child("render"));
  if (o.no_noise) {
    render.noise_luma = 0.0;
    render.noise_chroma = 0.0;
  }
  render.motion_blur_samples = 1;
  auto renderer = std::make_unique<camera::SimRenderer>(model.mirror, f, render);
  return rt::SimCamera{model.mirror, std::move(table), std::move(f), std::move(renderer), {}};
}

std::vector<LinePoint> syntheticPointsAt(const field::FieldModel& f, const Pose2& pose,
                                         const Options& o) {
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<LinePoint> out;
  const double c = std::cos(pose.phi), s = std::sin(pose.phi);
  for (const Vec2& p : f.sampleLines(0.02)) {
    const double dx = p.x() - pose.x, dy = p.y() - pose.y;
    if (std::hypot(dx, dy) > o.synthetic_range) continue;
    LinePoint q;
    q.x = static_cast<float>(c * dx + s * dy + o.synthetic_sigma * noise(rng));
    q.y = static_cast<float>(-s * dx + c * dy + o.synthetic_sigma * noise(rng));
    out.push_back(q);
  }
  return out;
}

std::vector<LinePoint> linePointsAt(rt::SimCamera& sim, const Pose2& pose, const Options& o) {
  if (o.synthetic) return syntheticPointsAt(sim.field, pose, o);
  const int frames = o.frames;
  rt::FrameProcessor processor(sim.mirror, sim.table, rt::defaultVisionParams());
  camera::SimScene scene;
  scene.robot = pose;
  return sim.track(processor, scene, frames).lines.points;
}

// Signed distance of a field point to a line element's centre: positive on the side of the
// element's left normal (segments: left of a -> b; arcs: outside the circle).
struct Signed {
  std::string element;
  double distance = 0.0;
  Vec2 normal = Vec2::Zero();
  Vec2 closest = Vec2::Zero();
};

Signed signedDistance(const field::FieldModel& f, const Vec2& p) {
  const field::FieldModel::Closest c = f.closestPoint(p);
  Signed s;
  if (c.is_arc) {
    const field::LineArc& arc = f.arcs()[static_cast<std::size_t>(c.element)];
    s.element = "arc" + std::to_string(c.element);
    s.normal = (c.point - arc.centre).normalized();
  } else {
    const field::LineSegment& seg = f.segments()[static_cast<std::size_t>(c.element)];
    s.element = "seg" + std::to_string(c.element);
    const Vec2 t = (seg.b - seg.a).normalized();
    s.normal = Vec2(-t.y(), t.x());
  }
  s.distance = (p - c.point).dot(s.normal);
  s.closest = c.point;
  return s;
}

Vec2 toField(const Pose2& pose, const LinePoint& q) {
  const double c = std::cos(pose.phi), s = std::sin(pose.phi);
  return {pose.x + c * q.x - s * q.y, pose.y + s * q.x + c * q.y};
}

int runMap(const Options& o, rt::SimCamera& sim, const fusion::LineMatcher& matcher) {
  const double hx = sim.field.length() / 2 + 0.5, hy = sim.field.width() / 2 + 0.5;
  std::printf("x,y,phi,points,inliers,dx_cm,dy_cm,dphi_deg,sx_cm,sy_cm,cost_cm\n");
  // A grid centred on the field, so that it reaches as far beyond the lines on every side.
  const int nx = static_cast<int>(std::floor(2 * hx / o.step_m + 1e-9));
  const int ny = static_cast<int>(std::floor(2 * hy / o.step_m + 1e-9));
  for (int iy = 0; iy <= ny; ++iy) {
    const double y = (iy - 0.5 * ny) * o.step_m;
    for (int ix = 0; ix <= nx; ++ix) {
      const double x = (ix - 0.5 * nx) * o.step_m;
      for (int h = 0; h < o.headings; ++h) {
        const Pose2 truth{
            x, y,
            fieldline::geometry::normalizeAngle(0.3 + h * 2.0 * std::numbers::pi / o.headings)};
        const std::vector<LinePoint> points = linePointsAt(sim, truth, o);
        Pose2 guess = truth;
        guess.x += o.offset_m;
        const fusion::PoseCorrection c = matcher.correct(points, guess);
        if (!c.valid) {
          std::printf("%.2f,%.2f,%.3f,%zu,%d,nan,nan,nan,nan,nan,nan\n", x, y, truth.phi,
                      points.size(), c.inliers);
          continue;
        }
        std::printf(
            "%.2f,%.2f,%.3f,%zu,%d,%.3f,%.3f,%.4f,%.3f,%.3f,%.3f\n", x, y, truth.phi, points.size(),
            c.inliers, 100 * (c.pose.x - truth.x), 100 * (c.pose.y - truth.y),
            fieldline::geometry::angleDiff(c.pose.phi, truth.phi) * 180 / std::numbers::pi,
            100 * std::sqrt(c.covariance(0, 0)), 100 * std::sqrt(c.covariance(1, 1)), 100 * c.cost);
      }
    }
  }
  return 0;
}

// Per point at the true pose: the element, signed distance, range, bearing, and the signed
// distance along the range direction (the radial component of the misplacement).
struct Sum {
  int n = 0;
  double d = 0, d2 = 0, radial = 0, pixel = 0;
  int pixel_n = 0;
};

struct Sums {
  std::map<std::string, Sum> by_element;
  std::map<int, Sum> by_range;
};

// One line point's misplacement at the true pose, added to the sums (and printed with --points).
void addPoint(const Options& o, rt::SimCamera& sim, const Pose2& truth, const LinePoint& q,
              Sums& sums) {
  auto& by_element = sums.by_element;
  auto& by_range = sums.by_range;
  const double cr = std::cos(truth.phi), sn = std::sin(truth.phi);
  const double range = std::hypot(q.x, q.y);
  if (o.max_range > 0 && range > o.max_range) return;
  const Vec2 p = toField(truth, q);
  const Signed s = signedDistance(sim.field, p);
  if (std::abs(s.distance) > 0.5) return;
  // The misplacement vector is s.distance * normal; its component along the ray from the robot.
  const Vec2 ray = (p - Vec2(truth.x, truth.y)).normalized();
  const double radial = s.distance * s.normal.dot(ray);
  // Where the line's centre (the closest model point) appears in the image, and the point's
  // pixel offset from it along the image's radius (+ outward): the detector's placement.
  const Vec2 off = s.closest - Vec2(truth.x, truth.y);
  const Vec2 centre_robot(cr * off.x() + sn * off.y(), -sn * off.x() + cr * off.y());
  const std::optional<Vec2> centre_pixel = sim.mirror.robotToImage(centre_robot);
  const Vec2 pixel(q.u, q.v);
  double pixel_radial = std::numeric_limits<double>::quiet_NaN();
  if (centre_pixel) {
    const Vec2 outward = (*centre_pixel - sim.mirror.params().centre).normalized();
    pixel_radial = (pixel - *centre_pixel).dot(outward);
  }
  // The floor table's point against the mirror model's own inverse at the same pixel.
  const std::optional<Vec2> exact = sim.mirror.imageToRobot(pixel);
  const double table =
      exact ? 100 * (Vec2(q.x, q.y) - *exact).norm() : std::numeric_limits<double>::quiet_NaN();
  if (o.points) {
    std::printf("%.2f,%.2f,%.3f,%.3f,%.3f,%s,%.3f,%.3f,%.3f,%.3f\n", q.u, q.v, q.x, q.y, range,
                s.element.c_str(), 100 * s.distance, 100 * radial, pixel_radial, table);
  }
  for (Sum* sum : {&by_element[s.element], &by_range[static_cast<int>(range * 2)]}) {
    ++sum->n;
    sum->d += s.distance;
    sum->d2 += s.distance * s.distance;
    sum->radial += radial;
    if (std::isfinite(pixel_radial)) {
      sum->pixel += pixel_radial;
      ++sum->pixel_n;
    }
  }
}

void printSums(const Sums& sums) {
  const auto& by_element = sums.by_element;
  const auto& by_range = sums.by_range;
  std::printf(
      "# by element: element,n,mean_signed_cm,rms_cm,mean_radial_cm,mean_pixel_radial_px\n");
  for (const auto& [name, s] : by_element) {
    std::printf("# %s,%d,%.3f,%.3f,%.3f,%.3f\n", name.c_str(), s.n, 100 * s.d / s.n,
                100 * std::sqrt(s.d2 / s.n), 100 * s.radial / s.n,
                s.pixel_n > 0 ? s.pixel / s.pixel_n : 0.0);
  }
  std::printf(
      "# by range (0.5 m bins): "
      "from_m,n,mean_signed_cm,rms_cm,mean_radial_cm,mean_pixel_radial_px\n");
  for (const auto& [bin, s] : by_range) {
    std::printf("# %.1f,%d,%.3f,%.3f,%.3f,%.3f\n", bin * 0.5, s.n, 100 * s.d / s.n,
                100 * std::sqrt(s.d2 / s.n), 100 * s.radial / s.n,
                s.pixel_n > 0 ? s.pixel / s.pixel_n : 0.0);
  }
}

int runPose(const Options& o, rt::SimCamera& sim, const fusion::LineMatcher& matcher) {
  Pose2 truth;
  {
    std::stringstream in(o.pose);
    char comma1 = 0, comma2 = 0;
    if (!(in >> truth.x >> comma1 >> truth.y >> comma2 >> truth.phi) || comma1 != ',' ||
        comma2 != ',') {
      std::fprintf(stderr, "--pose wants x,y,phi\n");
      return 2;
    }
  }
  const std::vector<LinePoint> points = linePointsAt(sim, truth, o);
  Pose2 guess = truth;
  guess.x += o.offset_m;
  const fusion::PoseCorrection c = matcher.correct(points, guess);
  std::printf(
      "# pose %.3f,%.3f,%.3f: %zu points, valid %d, inliers %d, error (%.3f, %.3f) cm "
      "%.4f deg, sigma (%.3f, %.3f) cm, cost %.3f cm\n",
      truth.x, truth.y, truth.phi, points.size(), c.valid, c.inliers, 100 * (c.pose.x - truth.x),
      100 * (c.pose.y - truth.y),
      fieldline::geometry::angleDiff(c.pose.phi, truth.phi) * 180 / std::numbers::pi,
      100 * std::sqrt(c.covariance(0, 0)), 100 * std::sqrt(c.covariance(1, 1)), 100 * c.cost);
  Sums sums;
  if (o.points) {
    std::printf("u,v,rx,ry,range_m,element,signed_cm,radial_cm,pixel_radial_px,table_cm\n");
  }
  for (const LinePoint& q : points)
    addPoint(o, sim, truth, q, sums);
  printSums(sums);
  return c.valid ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{"Layer 2's bias on rendered still frames (docs/log/2026-12-02-fusion.md)"};
  Options o;
  app.add_option("--camera", o.camera, "Camera preset")->capture_default_str();
  app.add_option("--field", o.field, "Field preset")->capture_default_str();
  app.add_flag("--no-noise", o.no_noise, "Render without sensor noise");
  app.add_option("--frames", o.frames, "Frames tracked per pose (the last one's points are used)")
      ->check(cli::Range(1, 100))
      ->capture_default_str();
  app.add_option("--offset", o.offset_m, "Start layer 2 this far off the truth along x, m")
      ->capture_default_str();
  app.add_option("--step", o.step_m, "--map: grid step, m")->check(cli::Range(0.05, 10.0));
  app.add_option("--headings", o.headings, "--map: headings per position")
      ->check(cli::Range(1, 64));
  app.add_flag("--map", o.map, "Grid of poses over the field");
  app.add_option("--pose", o.pose, "One pose in detail: x,y,phi");
  app.add_flag("--points", o.points, "--pose: print every point");
  app.add_option("--max-range", o.max_range, "--pose: only points within this range, m");
  app.add_flag("--synthetic", o.synthetic,
               "Model line points (every 2 cm of the lines' centres) instead of rendered ones");
  app.add_option("--synthetic-range", o.synthetic_range, "--synthetic: range, m")
      ->capture_default_str();
  app.add_option("--synthetic-sigma", o.synthetic_sigma, "--synthetic: scatter per axis, m")
      ->capture_default_str();
  app.add_option("--seed", o.seed, "--synthetic: random seed")->capture_default_str();
  app.add_option("--grid-cache", o.grid_cache, "Directory of the distance grid's cache")
      ->capture_default_str();
  FIELDLINE_CLI_PARSE(app, argc, argv);
  if (o.map && !o.pose.empty()) {
    std::fprintf(stderr, "either --map or --pose\n");
    return 2;
  }
  try {
    rt::SimCamera sim = loadCamera(o);
    const fusion::LineMatcher matcher(sim.field, fusion::withCalibratedCamera({}), o.grid_cache);
    if (o.map) return runMap(o, sim, matcher);
    if (!o.pose.empty()) return runPose(o, sim, matcher);
    std::fprintf(stderr, "either --map or --pose\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}
