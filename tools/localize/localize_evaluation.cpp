#include "tools/localize/localize_evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

#include <fmt/format.h>
#include <Eigen/Cholesky>

namespace fieldline::localize_eval {
namespace {

constexpr double kPi = std::numbers::pi;

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const auto index = static_cast<std::size_t>(std::min<double>(
      static_cast<double>(values.size() - 1), std::floor(q * static_cast<double>(values.size()))));
  return values[index];
}

}  // namespace

std::string CameraError::describe() const {
  return fmt::format(
      "scale {:+.1f} %, centre ({:+.1f}, {:+.1f}) px, axis ({:+.3f}, {:+.3f}) m, tilt {:+.1f} % "
      "toward {:.0f} deg",
      100.0 * scale, centre_px.x(), centre_px.y(), axis_offset_m.x(), axis_offset_m.y(),
      100.0 * tilt, tilt_bearing * 180.0 / kPi);
}

camera::MirrorModel trueMirror(const camera::MirrorModel& configured, const CameraError& error) {
  camera::MirrorParams p = configured.params();
  p.centre += error.centre_px;
  p.axis_offset += error.axis_offset_m;
  // The distance function as a sector table: the configured one scaled, and per bearing by the
  // tilt's cosine. Knots every 2 px out to the mirror's edge (the renderer maps every pixel).
  const camera::DistanceFunction& d = configured.params().distance;
  camera::CalibrationTableParams table;
  const double last = std::min(d.maxRadius(), p.outer_radius + 4.0);
  for (double r = 2.0; r <= last; r += 2.0)
    table.radii.push_back(r);
  constexpr int kSectors = 24;
  for (int s = 0; s < kSectors; ++s) {
    const double bearing = -kPi + 2.0 * kPi * (s + 1) / kSectors;
    table.sector_bearings.push_back(bearing);
    std::vector<double> distances;
    const double factor =
        (1.0 + error.scale) * (1.0 + error.tilt * std::cos(bearing - error.tilt_bearing));
    for (const double r : table.radii)
      distances.push_back(factor * d.floorDistance(r, bearing));
    table.distances.push_back(std::move(distances));
  }
  p.distance = camera::DistanceFunction(table);
  return camera::MirrorModel(p);
}

std::vector<FrameResult> evaluateLocalization(const region_tracking::SimCamera& sim,
                                              const region_tracking::VisionParams& vision,
                                              const LocalizeEvalOptions& options,
                                              const std::function<void(int)>& progress) {
  if (options.cameras < 1 || options.poses < 1) {
    throw std::invalid_argument("localize evaluation: cameras and poses must be at least 1");
  }
  const fusion::LineMatcher matcher(sim.field, options.matcher);
  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  const auto direction = [&] {
    const double a = uniform(-kPi, kPi);
    return camera::Vec2(std::cos(a), std::sin(a));
  };
  std::vector<FrameResult> out;
  for (int cam = 0; cam < options.cameras; ++cam) {
    CameraError error;
    error.scale = uniform(-options.max_scale, options.max_scale);
    error.centre_px = direction() * uniform(0.0, options.max_centre_px);
    error.axis_offset_m = direction() * uniform(0.0, options.max_axis_offset_m);
    error.tilt = uniform(0.0, options.max_tilt);
    error.tilt_bearing = uniform(-kPi, kPi);
    camera::SimRenderer renderer(trueMirror(sim.mirror, error), sim.field, sim.renderer->params());
    std::vector<std::uint8_t> frame;
    for (int k = 0; k < options.poses; ++k) {
      FrameResult r;
      r.camera = cam;
      r.truth = {uniform(-sim.field.length() / 2, sim.field.length() / 2),
                 uniform(-sim.field.width() / 2, sim.field.width() / 2), uniform(-kPi, kPi)};
      region_tracking::FrameProcessor processor(sim.mirror, sim.table, vision);
      region_tracking::VisionResult result;
      camera::SimScene scene;
      scene.robot = r.truth;
      // A few frames: the tracker settles on its regions.
      for (int f = 0; f < 3; ++f) {
        scene.frame_number = static_cast<std::uint64_t>(cam * 1000 + k * 3 + f);
        renderer.render(scene, frame);
        processor.process(renderer.view(frame), true, result);
      }
      const std::vector<perception::LinePoint>& points = result.lines.points;
      if (options.global) {
        const std::vector<fusion::PoseCorrection> answers = matcher.globalSearch(points);
        // The answer nearest the truth or its twin: which twin is not layer 2's business.
        double nearest = 1e9;
        for (const fusion::PoseCorrection& a : answers) {
          const double d = std::min(std::hypot(a.pose.x - r.truth.x, a.pose.y - r.truth.y),
                                    std::hypot(a.pose.x + r.truth.x, a.pose.y + r.truth.y));
          if (d < nearest) {
            nearest = d;
            r.correction = a;
          }
        }
        if (!answers.empty() &&
            std::hypot(r.correction.pose.x + r.truth.x, r.correction.pose.y + r.truth.y) <
                std::hypot(r.correction.pose.x - r.truth.x, r.correction.pose.y - r.truth.y)) {
          r.correction.pose =
              geometry::Pose2{-r.correction.pose.x, -r.correction.pose.y,
                              geometry::normalizeAngle(r.correction.pose.phi + kPi)};
        }
      } else {
        const camera::Vec2 shift = direction() * options.guess_m;
        const double turn = (unit(rng) < 0.5 ? -1.0 : 1.0) * options.guess_rad;
        r.correction = matcher.correct(
            points, {r.truth.x + shift.x(), r.truth.y + shift.y(), r.truth.phi + turn});
      }
      const Eigen::Vector3d e(r.correction.pose.x - r.truth.x, r.correction.pose.y - r.truth.y,
                              geometry::angleDiff(r.correction.pose.phi, r.truth.phi));
      r.position_error = e.head<2>().norm();
      r.heading_error = std::abs(e.z());
      r.nees = r.correction.valid ? e.dot(r.correction.covariance.ldlt().solve(e)) : 0.0;
      out.push_back(r);
    }
    if (progress) progress(static_cast<int>(out.size()));
  }
  return out;
}

LocalizeEvalSummary summarize(const std::vector<FrameResult>& frames) {
  LocalizeEvalSummary s;
  s.frames = static_cast<int>(frames.size());
  std::vector<double> position, heading, sigma, deltas;
  for (const FrameResult& f : frames) {
    if (!f.correction.valid) continue;
    ++s.valid;
    if (f.nees < kNeesLow) {
      ++s.below;
    } else if (f.nees > kNeesHigh) {
      ++s.above;
    } else {
      ++s.in_band;
    }
    position.push_back(f.position_error);
    heading.push_back(f.heading_error);
    sigma.push_back(std::sqrt(f.correction.covariance(0, 0) + f.correction.covariance(1, 1)));
    if (f.correction.has_runner_up) {
      ++s.runner_ups;
      deltas.push_back(f.correction.runner_up_delta);
    }
  }
  if (!position.empty()) {
    double sum_p = 0.0, sum_h = 0.0;
    for (std::size_t i = 0; i < position.size(); ++i) {
      sum_p += position[i];
      sum_h += heading[i];
    }
    s.position_mean_m = sum_p / static_cast<double>(position.size());
    s.heading_mean_rad = sum_h / static_cast<double>(heading.size());
    s.position_p95_m = percentile(position, 0.95);
    s.sigma_median_m = percentile(sigma, 0.5);
  }
  return s;
}

std::string summaryLine(const LocalizeEvalSummary& s) {
  return fmt::format(
      "frames={} valid={} nees_in_band={:.3f} below={} above={} pos_mean_m={:.4f} "
      "pos_p95_m={:.4f} heading_mean_deg={:.2f} sigma_median_m={:.4f} runner_ups={}",
      s.frames, s.valid, s.inBand(), s.below, s.above, s.position_mean_m, s.position_p95_m,
      s.heading_mean_rad * 180.0 / kPi, s.sigma_median_m, s.runner_ups);
}

}  // namespace fieldline::localize_eval
