// Mirror calibration from rings: stages 1-5 in order, and the files (the camera config written,
// the ring distances read).
#include "tools/mirror_calibrate/mirror_calibration.hpp"
#include "tools/mirror_calibrate/numbers.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>
#include <stdexcept>

#include <fmt/core.h>

namespace fieldline::calibration {

namespace {

// Each peak assigned to the ring whose radius `fit` predicts nearest to it at the peak's
// bearing, within 0.4 of the gap to the neighbouring rings (at most 4 px); peaks farther from
// every ring are dropped.
std::vector<RingPoint> assignToRings(const std::vector<RingPeak>& peaks, const RingFit& fit,
                                     const camera::MirrorParams& base, int n) {
  std::vector<RingPoint> pts;
  for (const RingPeak& p : peaks) {
    const double b = axisBearing(p.pixel, fit.centre, base.heading_angle, base.mirrored);
    int best = -1;
    double bestDist = 1e9;
    double gate = 0.0;
    std::vector<double> pred(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k)
      pred[static_cast<std::size_t>(k)] = fit.ringRadius(k, b);
    for (int k = 0; k < n; ++k) {
      const double dk = std::abs(p.radius - pred[static_cast<std::size_t>(k)]);
      if (dk < bestDist) {
        bestDist = dk;
        best = k;
        const double lo =
            k > 0 ? pred[static_cast<std::size_t>(k)] - pred[static_cast<std::size_t>(k - 1)] : 1e9;
        const double hi =
            k + 1 < n ? pred[static_cast<std::size_t>(k + 1)] - pred[static_cast<std::size_t>(k)]
                      : 1e9;
        gate = 0.4 * std::min({lo, hi, 10.0});
      }
    }
    if (best >= 0 && bestDist <= gate) pts.push_back({p.pixel, best});
  }
  return pts;
}

}  // namespace

// --- stages 1-5 ---

RingCalibration calibrateFromRings(const GreyImage& image, const std::vector<double>& distances,
                                   const camera::MirrorParams& base,
                                   const RingCalibrationParams& params) {
  if (image.width != base.width || image.height != base.height) {
    throw std::invalid_argument(
        fmt::format("mirror calibration: the image is {}x{} but the camera config says {}x{}",
                    image.width, image.height, base.width, base.height));
  }
  RingCalibration out;
  const int rays = params.search.rays;
  const std::vector<RingPeak> first = findRingPeaks(image, base.centre, params.search);
  const std::vector<TracedRing> traced = traceRings(first, rays, base.centre, 0.3, 1.0);
  if (traced.size() < 4) {
    throw std::invalid_argument(fmt::format(
        "mirror calibration: {} rings found around ({:.1f}, {:.1f}) between {} and {} px (4 or "
        "more needed): check the centre guess, the radii searched and --min-contrast",
        traced.size(), base.centre.x(), base.centre.y(), params.search.min_radius,
        params.search.max_radius));
  }
  for (const TracedRing& t : traced)
    out.found_radii.push_back(t.radius);
  out.match = matchRings(out.found_radii, distances);
  out.distances.assign(distances.begin() + out.match.first_distance,
                       distances.begin() + out.match.first_distance + out.match.count);
  // First points: the traced rings' points; start: the outermost matched ring's centre (least
  // moved by an axis offset) and the traced radii.
  std::vector<double> radii;
  for (int k = 0; k < out.match.count; ++k) {
    const TracedRing& t = traced[static_cast<std::size_t>(out.match.first_ring + k)];
    radii.push_back(t.radius);
    for (const Vec2& p : t.pixels)
      out.points.push_back({p, k});
  }
  const Vec2 start =
      traced[static_cast<std::size_t>(out.match.first_ring + out.match.count - 1)].centre;
  out.fit = fitRings(out.points, out.distances, base, start, radii, params.fit);
  // Rounds: search again around the fitted centre; assign each peak to the predicted ring
  // nearest to it (within 0.4 of the gap to the neighbours); fit again.
  for (int round = 0; round < params.rounds; ++round) {
    const std::vector<RingPeak> peaks = findRingPeaks(image, out.fit.centre, params.search);
    const std::vector<RingPoint> pts = assignToRings(peaks, out.fit, base, out.match.count);
    out.points = pts;
    out.fit = fitRings(out.points, out.distances, base, out.fit.centre, out.fit.radii, params.fit);
  }
  out.table = sectorTable(out.fit, out.points, base, params.sectors, params.radius_step);
  out.mirror = base;
  out.mirror.centre = out.fit.centre;
  out.mirror.axis_offset = out.fit.axis_offset;
  out.mirror.distance = camera::DistanceFunction(out.table.table);
  const double end = out.table.table.radii.back();
  out.mirror.useful_radius = std::min(base.useful_radius, end);
  if (!(out.mirror.useful_radius > out.mirror.self_radius)) {
    throw std::invalid_argument(fmt::format(
        "mirror calibration: the outermost ring ({:.1f} px) lies inside the robot's reflection "
        "({:.1f} px)",
        end, base.self_radius));
  }
  out.mirror.outer_radius = std::max(base.outer_radius, out.mirror.useful_radius);
  return out;
}

// --- files ---

namespace {

std::string list(const std::vector<double>& v, int decimals) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) {
    s += (i ? ", " : "") + fmt::format("{:.{}f}", v[i], decimals);
  }
  return s + "]";
}

}  // namespace

std::string cameraYaml(const camera::MirrorParams& m, const std::string& colour_table,
                       double frame_rate, double exposure, double latency,
                       const std::string& comment) {
  const auto* t = std::get_if<camera::CalibrationTableParams>(&m.distance.params());
  if (t == nullptr) throw std::invalid_argument("cameraYaml: the mirror has no calibration table");
  std::string s;
  std::istringstream lines(comment);
  for (std::string line; std::getline(lines, line);)
    s += "# " + line + "\n";
  s += fmt::format("\nimage:\n  width: {}\n  height: {}\n\n", m.width, m.height);
  s += "mirror:\n";
  s += fmt::format("  centre: [{:.3f}, {:.3f}]\n", m.centre.x(), m.centre.y());
  s += fmt::format("  heading_angle: {:.6f}\n", m.heading_angle);
  s += fmt::format("  mirrored: {}\n", m.mirrored ? "true" : "false");
  s += fmt::format("  outer_radius: {:.3f}\n", m.outer_radius);
  // Rounded down: never beyond the table's last radius.
  s += fmt::format("  useful_radius: {:.3f}\n", std::floor(m.useful_radius * 1000.0) / 1000.0);
  s += fmt::format("  self_radius: {:.3f}\n", m.self_radius);
  s += fmt::format("  reference_height: {:.4f}\n", m.reference_height);
  s += "  # Where the mirror axis stands in the robot frame (x forward, y left), m.\n";
  s += fmt::format("  axis_offset: [{:.4f}, {:.4f}]\n", m.axis_offset.x(), m.axis_offset.y());
  s += "  distance_function:\n    type: table\n";
  s += "    radii: " + list(t->radii, 3) + "\n    sectors:\n";
  for (std::size_t k = 0; k < t->sector_bearings.size(); ++k) {
    // Rounded toward zero so that pi stays within the loader's range (-pi, pi].
    const double b = std::trunc(t->sector_bearings[k] * 1e9) / 1e9;
    s += fmt::format("      - bearing: {:.9f}\n", b);
    s += "        distances: " + list(t->distances[k], 4) + "\n";
  }
  s += fmt::format("\ncolour_table: {}\n\n", colour_table);
  s += fmt::format("pipeline:\n  frame_rate: {}\n  exposure: {}\n  latency: {}\n", frame_rate,
                   exposure, latency);
  return s;
}

std::vector<double> parseDistances(const std::string& text_or_path) {
  std::vector<double> out;
  std::ifstream file(text_or_path);
  if (file) {
    // `distN = value` lines, millimetres.
    const std::regex line(R"(^\s*dist\d+\s*=\s*([-+0-9.eE]+)\s*$)");
    std::string text;
    int lineNo = 0;
    while (std::getline(file, text)) {
      ++lineNo;
      std::smatch m;
      if (!std::regex_match(text, m, line)) continue;
      const double mm = std::stod(m[1].str());
      if (!std::isfinite(mm) || mm < 0.0) {
        throw std::invalid_argument(
            fmt::format("{}:{}: a ring distance must be >= 0 mm", text_or_path, lineNo));
      }
      if (mm > 0.0) out.push_back(mm / 1000.0);
    }
    if (out.empty()) {
      throw std::invalid_argument(text_or_path + ": no `distN = <mm>` lines with a distance > 0");
    }
  } else {
    std::stringstream in(text_or_path);
    for (std::string item; std::getline(in, item, ',');) {
      std::size_t used = 0;
      double v = kNaN;
      try {
        v = std::stod(item, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != item.size() || !std::isfinite(v) || v <= 0.0) {
        throw std::invalid_argument("ring distances: '" + item +
                                    "' is not a distance > 0 in metres (nor is '" + text_or_path +
                                    "' a readable file)");
      }
      out.push_back(v);
    }
  }
  std::sort(out.begin(), out.end());
  for (std::size_t i = 1; i < out.size(); ++i) {
    if (out[i] == out[i - 1]) throw std::invalid_argument("ring distances: a distance repeats");
  }
  return out;
}

}  // namespace fieldline::calibration
