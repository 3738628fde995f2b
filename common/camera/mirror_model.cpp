#include "common/camera/mirror_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "common/camera/colour.hpp"
#include "common/config/paths.hpp"

namespace fieldline::camera {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kTwoPi = 2.0 * std::numbers::pi;

bool positiveFinite(double x) {
  return std::isfinite(x) && x > 0.0;
}

void requireTable(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("calibration table: " + what);
}

// Angle in [0, 2 pi).
double wrapPositive(double a) {
  double w = std::fmod(a, kTwoPi);
  if (w < 0.0) w += kTwoPi;
  return w;
}

}  // namespace

// --- DistanceFunction ---

DistanceFunction::DistanceFunction(const LinearExponentialParams& p) : params_(p) {
  if (!positiveFinite(p.slope) || !positiveFinite(p.growth) || !std::isfinite(p.knee_radius) ||
      p.knee_radius < 0.0) {
    throw std::invalid_argument(
        "linear-exponential distance function: slope and growth must be > 0, knee_radius >= 0");
  }
}

DistanceFunction::DistanceFunction(const CalibrationTableParams& p) : params_(p) {
  requireTable(!p.radii.empty(), "no radii");
  requireTable(!p.sector_bearings.empty(), "no sectors");
  requireTable(p.distances.size() == p.sector_bearings.size(),
               "one distance list per sector bearing expected");
  for (std::size_t i = 0; i < p.radii.size(); ++i) {
    requireTable(positiveFinite(p.radii[i]) && (i == 0 || p.radii[i] > p.radii[i - 1]),
                 "radii must be finite, > 0 and strictly increasing");
  }
  for (std::size_t s = 0; s < p.sector_bearings.size(); ++s) {
    const double b = p.sector_bearings[s];
    requireTable(std::isfinite(b), "sector bearing not finite");
    if (p.sector_bearings.size() > 1) {
      requireTable(b > -std::numbers::pi && b <= std::numbers::pi &&
                       (s == 0 || b > p.sector_bearings[s - 1]),
                   "sector bearings must be strictly increasing within (-pi, pi]");
    }
    const auto& d = p.distances[s];
    requireTable(d.size() == p.radii.size(), "each sector needs one distance per radius");
    for (std::size_t i = 0; i < d.size(); ++i) {
      requireTable(positiveFinite(d[i]) && (i == 0 || d[i] > d[i - 1]),
                   "distances must be finite, > 0 and strictly increasing");
    }
  }
}

DistanceFunction::SectorBlend DistanceFunction::blend(double bearing) const {
  const auto& t = std::get<CalibrationTableParams>(params_);
  const std::size_t n = t.sector_bearings.size();
  if (n == 1) return {0, 0, 0.0};
  // Find the sector at or before `bearing` going counter-clockwise, cyclically.
  const double b = wrapPositive(bearing - t.sector_bearings[0]);
  std::size_t lower = n - 1;
  for (std::size_t s = 1; s < n; ++s) {
    if (wrapPositive(t.sector_bearings[s] - t.sector_bearings[0]) > b) {
      lower = s - 1;
      break;
    }
  }
  const std::size_t upper = (lower + 1) % n;
  const double span = upper == 0
                          ? kTwoPi - wrapPositive(t.sector_bearings[lower] - t.sector_bearings[0])
                          : t.sector_bearings[upper] - t.sector_bearings[lower];
  const double into = wrapPositive(bearing - t.sector_bearings[lower]);
  return {lower, upper, std::clamp(into / span, 0.0, 1.0)};
}

double DistanceFunction::tableDistanceAt(std::size_t knot, const SectorBlend& b) const {
  const auto& t = std::get<CalibrationTableParams>(params_);
  return t.distances[b.lower][knot] * (1.0 - b.weight) + t.distances[b.upper][knot] * b.weight;
}

double DistanceFunction::floorDistance(double radius, double bearing) const {
  if (!std::isfinite(radius) || radius < 0.0) return kNaN;
  if (const auto* le = std::get_if<LinearExponentialParams>(&params_)) {
    if (radius <= le->knee_radius) return le->slope * radius;
    return le->slope * le->knee_radius +
           le->slope / le->growth * std::expm1(le->growth * (radius - le->knee_radius));
  }
  const auto& t = std::get<CalibrationTableParams>(params_);
  if (radius > t.radii.back() || !std::isfinite(bearing)) return kNaN;
  const SectorBlend b = blend(bearing);
  const auto it = std::lower_bound(t.radii.begin(), t.radii.end(), radius);
  const std::size_t i = static_cast<std::size_t>(it - t.radii.begin());
  const double r0 = i == 0 ? 0.0 : t.radii[i - 1];
  const double d0 = i == 0 ? 0.0 : tableDistanceAt(i - 1, b);
  const double d1 = tableDistanceAt(i, b);
  return d0 + (d1 - d0) * (radius - r0) / (t.radii[i] - r0);
}

double DistanceFunction::imageRadius(double distance, double bearing) const {
  if (!std::isfinite(distance) || distance < 0.0) return kNaN;
  if (const auto* le = std::get_if<LinearExponentialParams>(&params_)) {
    const double knee_distance = le->slope * le->knee_radius;
    if (distance <= knee_distance) return distance / le->slope;
    return le->knee_radius +
           std::log1p((distance - knee_distance) * le->growth / le->slope) / le->growth;
  }
  const auto& t = std::get<CalibrationTableParams>(params_);
  if (!std::isfinite(bearing)) return kNaN;
  const SectorBlend b = blend(bearing);
  // The blended distances are strictly increasing: find the first knot at or beyond `distance`.
  std::size_t lo = 0;
  std::size_t hi = t.radii.size();
  while (lo < hi) {
    const std::size_t mid = (lo + hi) / 2;
    if (tableDistanceAt(mid, b) < distance) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  if (lo == t.radii.size()) return kNaN;
  const double r0 = lo == 0 ? 0.0 : t.radii[lo - 1];
  const double d0 = lo == 0 ? 0.0 : tableDistanceAt(lo - 1, b);
  const double d1 = tableDistanceAt(lo, b);
  return r0 + (t.radii[lo] - r0) * (distance - d0) / (d1 - d0);
}

double DistanceFunction::metresPerPixel(double radius, double bearing) const {
  if (!std::isfinite(radius) || radius < 0.0) return kNaN;
  if (const auto* le = std::get_if<LinearExponentialParams>(&params_)) {
    if (radius <= le->knee_radius) return le->slope;
    return le->slope * std::exp(le->growth * (radius - le->knee_radius));
  }
  const auto& t = std::get<CalibrationTableParams>(params_);
  if (radius > t.radii.back() || !std::isfinite(bearing)) return kNaN;
  const SectorBlend b = blend(bearing);
  const auto it = std::lower_bound(t.radii.begin(), t.radii.end(), radius);
  const std::size_t i = static_cast<std::size_t>(it - t.radii.begin());
  const double r0 = i == 0 ? 0.0 : t.radii[i - 1];
  const double d0 = i == 0 ? 0.0 : tableDistanceAt(i - 1, b);
  return (tableDistanceAt(i, b) - d0) / (t.radii[i] - r0);
}

double DistanceFunction::maxRadius() const {
  if (std::holds_alternative<LinearExponentialParams>(params_)) {
    return std::numeric_limits<double>::infinity();
  }
  return std::get<CalibrationTableParams>(params_).radii.back();
}

DistanceFunction DistanceFunction::scaled(double factor) const {
  if (!positiveFinite(factor)) throw std::invalid_argument("scale factor must be > 0");
  if (const auto* le = std::get_if<LinearExponentialParams>(&params_)) {
    return DistanceFunction(
        LinearExponentialParams{le->slope / factor, le->knee_radius * factor, le->growth / factor});
  }
  CalibrationTableParams t = std::get<CalibrationTableParams>(params_);
  for (double& r : t.radii)
    r *= factor;
  return DistanceFunction(t);
}

// --- MirrorModel ---

MirrorModel::MirrorModel(MirrorParams params)
    : params_(std::move(params)), sign_(params_.mirrored ? 1.0 : -1.0) {
  const MirrorParams& p = params_;
  if (p.width <= 0 || p.height <= 0) throw std::invalid_argument("mirror: image size must be > 0");
  if (!p.centre.allFinite() || !std::isfinite(p.heading_angle)) {
    throw std::invalid_argument("mirror: centre and heading_angle must be finite");
  }
  if (!(std::isfinite(p.self_radius) && p.self_radius >= 0.0 && p.useful_radius > p.self_radius &&
        std::isfinite(p.outer_radius) && p.outer_radius >= p.useful_radius)) {
    throw std::invalid_argument("mirror: radii must satisfy 0 <= self < useful <= outer");
  }
  if (!positiveFinite(p.reference_height)) {
    throw std::invalid_argument("mirror: reference_height must be > 0");
  }
  if (!p.axis_offset.allFinite() || p.axis_offset.norm() > 1.0) {
    throw std::invalid_argument("mirror: axis_offset must be finite and within 1 m");
  }
  if (p.distance.maxRadius() < p.useful_radius) {
    throw std::invalid_argument("mirror: the distance function ends before useful_radius");
  }
}

double MirrorModel::bearingOf(const Vec2& pixel) const {
  const Vec2 d = pixel - params_.centre;
  return std::remainder(sign_ * (std::atan2(d.y(), d.x()) - params_.heading_angle), kTwoPi);
}

Vec2 MirrorModel::imageDirection(double bearing) const {
  const double a = params_.heading_angle + sign_ * bearing;
  return {std::cos(a), std::sin(a)};
}

MirrorZone MirrorModel::zone(const Vec2& pixel) const {
  if (!pixel.allFinite() || pixel.x() < -0.5 || pixel.y() < -0.5 ||
      pixel.x() >= params_.width - 0.5 || pixel.y() >= params_.height - 0.5) {
    return MirrorZone::kOutside;
  }
  const double r = radiusOf(pixel);
  if (r > params_.outer_radius) return MirrorZone::kOutside;
  if (r < params_.self_radius) return MirrorZone::kSelf;
  if (r > params_.useful_radius || r > params_.distance.maxRadius()) return MirrorZone::kFar;
  return MirrorZone::kUseful;
}

std::vector<std::uint8_t> MirrorModel::dontTouchMask() const {
  std::vector<std::uint8_t> mask(static_cast<std::size_t>(params_.width) * params_.height);
  for (int v = 0; v < params_.height; ++v) {
    for (int u = 0; u < params_.width; ++u) {
      mask[static_cast<std::size_t>(v) * params_.width + u] = dontTouch(u, v) ? 1 : 0;
    }
  }
  return mask;
}

std::optional<Vec2> MirrorModel::imageToRobot(const Vec2& pixel) const {
  const std::optional<Vec2> in_axis = imageToAxis(pixel);
  if (!in_axis) return std::nullopt;
  return axisToRobot(*in_axis);
}

std::optional<Vec2> MirrorModel::robotToImage(const Vec2& floor_point) const {
  if (!floor_point.allFinite()) return std::nullopt;
  return axisToImage(robotToAxis(floor_point));
}

std::optional<Vec2> MirrorModel::imageToAxis(const Vec2& pixel) const {
  if (!pixel.allFinite()) return std::nullopt;
  const double r = radiusOf(pixel);
  if (r < params_.self_radius || r > params_.outer_radius) return std::nullopt;
  const double bearing = bearingOf(pixel);
  const double d = params_.distance.floorDistance(r, bearing);
  if (!std::isfinite(d)) return std::nullopt;
  return Vec2(d * std::cos(bearing), d * std::sin(bearing));
}

std::optional<Vec2> MirrorModel::axisToImage(const Vec2& floor_point) const {
  if (!floor_point.allFinite()) return std::nullopt;
  const double bearing = std::atan2(floor_point.y(), floor_point.x());
  const double r = params_.distance.imageRadius(floor_point.norm(), bearing);
  if (!std::isfinite(r) || r < params_.self_radius || r > params_.outer_radius) {
    return std::nullopt;
  }
  return Vec2(params_.centre + r * imageDirection(bearing));
}

std::optional<Vec2> MirrorModel::robotPointToImage(const Vec3& point) const {
  if (!point.allFinite() || point.z() >= params_.reference_height) return std::nullopt;
  const double scale = params_.reference_height / (params_.reference_height - point.z());
  return axisToImage(robotToAxis(point.head<2>()) * scale);
}

std::optional<Vec3> MirrorModel::imageToRobotAtHeight(const Vec2& pixel, double height) const {
  if (!std::isfinite(height) || height >= params_.reference_height) return std::nullopt;
  const std::optional<Vec2> floor = imageToAxis(pixel);
  if (!floor) return std::nullopt;
  const Vec2 xy =
      axisToRobot(*floor * ((params_.reference_height - height) / params_.reference_height));
  return Vec3(xy.x(), xy.y(), height);
}

std::size_t MirrorModel::imageToRobot(std::span<const Vec2> pixels, std::vector<Vec2>& out) const {
  out.clear();
  std::size_t skipped = 0;
  for (const Vec2& p : pixels) {
    if (const std::optional<Vec2> q = imageToRobot(p)) {
      out.push_back(*q);
    } else {
      ++skipped;
    }
  }
  return skipped;
}

Vec2 MirrorModel::metresPerPixel(const Vec2& pixel) const {
  const double r = radiusOf(pixel);
  const double bearing = bearingOf(pixel);
  const double radial = params_.distance.metresPerPixel(r, bearing);
  const double tangential = r > 0.0 ? params_.distance.floorDistance(r, bearing) / r : radial;
  return {radial, tangential};
}

MirrorModel MirrorModel::scaledTo(int width, int height) const {
  if (width <= 0 || height <= 0) throw std::invalid_argument("mirror: image size must be > 0");
  const double factor = static_cast<double>(width) / params_.width;
  if (std::abs(params_.height * factor - height) > 1.0) {
    throw std::invalid_argument("mirror: cannot scale a " + std::to_string(params_.width) + "x" +
                                std::to_string(params_.height) + " camera to " +
                                std::to_string(width) + "x" + std::to_string(height) +
                                " (aspect ratio differs)");
  }
  MirrorParams p = params_;
  p.width = width;
  p.height = height;
  // Pixel centres sit at integers: scale about the image's outer corner (-0.5, -0.5).
  p.centre = (params_.centre + Vec2(0.5, 0.5)) * factor - Vec2(0.5, 0.5);
  p.outer_radius *= factor;
  p.useful_radius *= factor;
  p.self_radius *= factor;
  p.distance = params_.distance.scaled(factor);
  return MirrorModel(p);
}

// --- loading ---

namespace {

DistanceFunction loadDistanceFunction(const config::Node& n) {
  const std::string type = n.getChoice("type", {"linear_exponential", "table"});
  try {
    if (type == "linear_exponential") {
      LinearExponentialParams p;
      p.slope = n.get<double>("slope", 1e-5, 1.0);
      p.knee_radius = n.get<double>("knee_radius", 0.0, 10000.0);
      p.growth = n.get<double>("growth", 1e-6, 1.0);
      n.rejectUnknownKeys();
      return DistanceFunction(p);
    }
    CalibrationTableParams p;
    p.radii = n.getList<double>("radii");
    const std::vector<config::Node> sectors = n.children("sectors");
    if (sectors.empty()) n.fail("sectors", "at least one sector expected");
    for (const config::Node& s : sectors) {
      p.sector_bearings.push_back(
          s.getOr<double>("bearing", 0.0, -std::numbers::pi, std::numbers::pi));
      p.distances.push_back(s.getList<double>("distances", p.radii.size()));
      s.rejectUnknownKeys();
    }
    n.rejectUnknownKeys();
    return DistanceFunction(p);
  } catch (const std::invalid_argument& e) {
    n.fail("", e.what());
  }
}

}  // namespace

CameraModel loadCameraModel(const config::Node& root) {
  const config::Node image = root.child("image");
  MirrorParams p;
  p.width = image.get<int>("width", 16, 8192);
  p.height = image.get<int>("height", 16, 8192);
  image.rejectUnknownKeys();

  const config::Node m = root.child("mirror");
  const std::vector<double> centre = m.getList<double>("centre", 2);
  p.centre = Vec2(centre[0], centre[1]);
  p.heading_angle = m.get<double>("heading_angle", -2.0 * std::numbers::pi, 2.0 * std::numbers::pi);
  p.mirrored = m.get<bool>("mirrored");
  const double diagonal = std::hypot(p.width, p.height);
  p.outer_radius = m.get<double>("outer_radius", 1.0, diagonal);
  p.useful_radius = m.get<double>("useful_radius", 1.0, diagonal);
  p.self_radius = m.get<double>("self_radius", 0.0, diagonal);
  p.reference_height = m.get<double>("reference_height", 0.05, 5.0);
  if (m.has("axis_offset")) {
    const std::vector<double> offset = m.getList<double>("axis_offset", 2);
    p.axis_offset = Vec2(offset[0], offset[1]);
  }
  p.distance = loadDistanceFunction(m.child("distance_function"));
  m.rejectUnknownKeys();

  CameraModel model;
  try {
    model.mirror = MirrorModel(p);
  } catch (const std::invalid_argument& e) {
    m.fail("", e.what());
  }
  // A bare name is a preset (config/camera/NAME.yaml); a path is relative to this file, so a
  // camera preset and its colour table written side by side at a venue stay together.
  const std::string named = root.get<std::string>("colour_table");
  model.colour_table = config::resolveAgainst(root.file(), "camera", named);
  // A preset that does not exist or does not load is this file's error, found when it is read
  // (not when region tracking first needs the table).
  try {
    (void)loadColourTablePreset(model.colour_table);
  } catch (const config::Error& e) {
    root.fail("colour_table", "colour table preset '" + named + "' does not load: " + e.what());
  }
  return model;
}

CameraModel loadCameraPreset(const std::string& name_or_path) {
  const config::Node root = config::Node::loadFile(config::resolvePreset("camera", name_or_path));
  CameraModel model = loadCameraModel(root);
  // Sections of the camera service: accepted here without being read.
  (void)root.childIf("render");
  (void)root.childIf("pipeline");
  root.rejectUnknownKeys();
  return model;
}

}  // namespace fieldline::camera
