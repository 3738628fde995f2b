// The omni-directional camera's optics (seed sections 1.3, 4.9 and 4.10): a camera looks up at
// a convex, rotationally symmetric mirror, so the image is a disc around the mirror centre C in
// which the angle between directions seen from the robot is preserved and image radius maps to
// floor distance through the mirror's distance function.
//
// Frames (docs/camera.md has a figure):
//   image:  column u to the right, row v down, origin at the top-left pixel, integer
//           coordinates at pixel centres.
//   robot:  origin on the floor under the robot's centre, x forward (heading), y left, metres.
//   axis:   the robot frame moved to the floor point under the mirror axis (same orientation).
//           On a real robot the mirror axis is 3-12 cm away from the robot's centre:
//           MirrorParams::axis_offset is where the axis stands in the robot frame (default 0, then
//           the two frames coincide). The mirror sees the floor from its axis, so image radius and
//           image angle belong to the axis frame; every robot-frame mapping below adds or removes
//           the offset.
//   bearing of an axis-frame point: atan2(y, x), counter-clockwise from the heading.
// A pixel at offset (du, dv) = pixel - C has image radius r = |(du, dv)| and image angle
// a = atan2(dv, du) (from +u toward +v). The robot's heading appears at a = heading_angle (the
// camera is mounted so that the image diagonal points forward); the convex mirror reverses the
// view, so with `mirrored` a point at bearing b appears at a = heading_angle + b, otherwise at
// heading_angle - b.
//
// Floor distance D(r) comes from a DistanceFunction: the seed's designed mirror (a linear part
// near the robot and an exponential part further out), or a calibration table for a real mirror
// that is neither perfectly round nor centred (distances at a list of radii, optionally per
// bearing sector, interpolated).
//
// 3-D points (seed 4.9.5): a point B at height h is seen along the ray from the reference point
// R (on the mirror axis at reference_height H) through B; that ray meets the floor at horizontal
// distance |B| * H / (H - h) in the same bearing, and B is imaged where that floor point is.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <variant>
#include <vector>

#include <Eigen/Core>

#include "common/config/config.hpp"

namespace fieldline::camera {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// The seed's designed mirror: D(r) = slope * r up to knee_radius, beyond it an exponential part
// slope * knee + (slope / growth) * (exp(growth * (r - knee)) - 1) that continues the linear part
// with the same slope (continuous and smooth at the knee).
struct LinearExponentialParams {
  // m per pixel of the linear part.
  double slope = 0.018;
  // Image radius where the exponential part starts, px.
  double knee_radius = 70.0;
  // Growth rate of the exponential part, 1/px.
  double growth = 0.048;
};

// A measured mirror: floor distances (m) at image radii (px). With one sector the mirror is
// taken as round; with several, each sector holds the distances measured along its bearing and
// a bearing between two sectors interpolates linearly (cyclically). Between radii the distance is
// interpolated linearly; below the first radius it runs linearly to (0 px, 0 m); beyond the last
// radius it is undefined.
struct CalibrationTableParams {
  // Strictly increasing, > 0, px.
  std::vector<double> radii;
  // Bearing of each sector (rad, robot frame), strictly increasing within (-pi, pi]; a single
  // sector may have any bearing.
  std::vector<double> sector_bearings;
  // distances[s][i]: floor distance (m) at radii[i] in sector s, strictly increasing in i.
  std::vector<std::vector<double>> distances;
};

class DistanceFunction {
 public:
  // Throws std::invalid_argument for non-positive or non-finite parameters.
  explicit DistanceFunction(const LinearExponentialParams& params);
  // Throws std::invalid_argument for a table that is empty, not increasing or ragged.
  explicit DistanceFunction(const CalibrationTableParams& params);

  // Floor distance (m) seen at image radius `radius` (px) along robot bearing `bearing` (rad).
  // NaN for a negative or non-finite radius or one beyond maxRadius().
  double floorDistance(double radius, double bearing) const;
  // The inverse: image radius (px) at which the floor at `distance` (m) appears. NaN for a
  // negative or non-finite distance or one beyond the function's range.
  double imageRadius(double distance, double bearing) const;
  // dD/dr at `radius`: metres of floor per pixel in the radial direction.
  double metresPerPixel(double radius, double bearing) const;
  // Largest radius with a defined distance (+inf for the linear-exponential function).
  double maxRadius() const;

  // The same mirror seen in an image scaled by `factor` (radii scale, distances stay).
  DistanceFunction scaled(double factor) const;

  bool isTable() const { return std::holds_alternative<CalibrationTableParams>(params_); }
  const std::variant<LinearExponentialParams, CalibrationTableParams>& params() const {
    return params_;
  }

 private:
  // Blend of the two sectors around `bearing`: distances[lower] * (1 - weight) + distances[upper]
  // * weight.
  struct SectorBlend {
    std::size_t lower = 0;
    std::size_t upper = 0;
    double weight = 0.0;
  };
  SectorBlend blend(double bearing) const;
  double tableDistanceAt(std::size_t knot, const SectorBlend& b) const;

  std::variant<LinearExponentialParams, CalibrationTableParams> params_;
};

struct MirrorParams {
  // Image size these parameters are given for, px.
  int width = 320;
  int height = 240;
  // Mirror centre C in the image, px (u, v).
  Vec2 centre{159.5, 119.5};
  // Direction of the robot's heading in the image, rad from +u toward +v (i.e. clockwise on the
  // screen). -0.6435 is the top-right diagonal of a 4:3 image.
  double heading_angle = -0.6435;
  // True if the mirror reverses the view (robot-left appears clockwise from the heading).
  bool mirrored = true;
  // Edge of the mirror in the image, px: outside it the image is black.
  double outer_radius = 155.0;
  // Radius up to which the floor is imaged well enough for measurements, px.
  double useful_radius = 135.0;
  // Radius of the robot's own reflection around C, px: no floor is seen inside.
  double self_radius = 14.0;
  // Height of the reference point R for 3-D points (seed 4.9.5), m.
  double reference_height = 0.6;
  // Where the mirror axis meets the floor, in the robot frame (m): the offset between the mirror
  // axis and the robot's centre. Zero puts the axis at the robot's centre.
  Vec2 axis_offset{0.0, 0.0};
  DistanceFunction distance{LinearExponentialParams{}};
};

// Where a pixel lies with respect to the mirror.
enum class MirrorZone : std::uint8_t {
  // Inside the robot's own reflection (r < self_radius).
  kSelf,
  // Floor usable for measurements (self_radius <= r <= useful_radius, distance defined).
  kUseful,
  // Inside the mirror but too far out to measure (useful_radius < r <= outer_radius, or beyond
  // the distance function's range).
  kFar,
  // Outside the mirror or outside the image.
  kOutside,
};

class MirrorModel {
 public:
  // Throws std::invalid_argument for inconsistent parameters (radii not ordered
  // self < useful <= outer, non-positive size or height, a table that ends before useful_radius).
  explicit MirrorModel(MirrorParams params);

  const MirrorParams& params() const { return params_; }
  int width() const { return params_.width; }
  int height() const { return params_.height; }

  // Image radius and bearing around the mirror axis (axis frame) of a pixel.
  double radiusOf(const Vec2& pixel) const { return (pixel - params_.centre).norm(); }
  double bearingOf(const Vec2& pixel) const;
  // Image direction (unit vector, px) in which axis-frame bearing `bearing` appears.
  Vec2 imageDirection(double bearing) const;

  // Axis frame <-> robot frame (a shift by axis_offset).
  Vec2 axisToRobot(const Vec2& in_axis) const { return in_axis + params_.axis_offset; }
  Vec2 robotToAxis(const Vec2& in_robot) const { return in_robot - params_.axis_offset; }
  // The floor point (axis frame, m) seen at `pixel`, and back; same rules as imageToRobot and
  // robotToImage.
  std::optional<Vec2> imageToAxis(const Vec2& pixel) const;
  std::optional<Vec2> axisToImage(const Vec2& floor_point_in_axis) const;

  MirrorZone zone(const Vec2& pixel) const;
  // True for pixels the vision must not use (the seed's "don't touch" mask): the robot's own
  // reflection and everything outside the useful radius.
  bool dontTouch(int u, int v) const { return zone(Vec2(u, v)) != MirrorZone::kUseful; }
  // dontTouch for every pixel, row-major width() * height(), 1 = don't touch.
  std::vector<std::uint8_t> dontTouchMask() const;

  // The floor point (robot frame, m) seen at `pixel`; nullopt inside the self reflection,
  // outside the mirror or beyond the distance function. Far pixels map too (check zone()).
  std::optional<Vec2> imageToRobot(const Vec2& pixel) const;
  // The pixel where the floor point `floor_point` (robot frame, m) appears; nullopt beyond the
  // distance function's range or the mirror's edge and for the robot's own footprint
  // (radius < self_radius).
  std::optional<Vec2> robotToImage(const Vec2& floor_point) const;
  // A 3-D point (robot frame, z up from the floor, m) to its pixel; nullopt also for points at or
  // above the reference height (their ray never meets the floor). The ray runs from R on the
  // mirror axis, so the point is projected about the axis, not the robot's centre.
  std::optional<Vec2> robotPointToImage(const Vec3& point) const;
  // The point at height `height` (m, below the reference height) seen at `pixel`: e.g. the ball's
  // centre, 0.11 m up.
  std::optional<Vec3> imageToRobotAtHeight(const Vec2& pixel, double height) const;

  // Undistorts a contour (seed 4.10): every pixel mapped to the floor. Pixels without a floor
  // point are skipped; returns how many were skipped. `out` is cleared first and keeps its
  // capacity, so a caller that reuses it allocates nothing per frame.
  std::size_t imageToRobot(std::span<const Vec2> pixels, std::vector<Vec2>& out) const;

  // Metres of floor per pixel at `pixel`, radially and tangentially (NaN where undefined).
  Vec2 metresPerPixel(const Vec2& pixel) const;

  // The same camera delivering frames of another size with the same aspect ratio (all pixel
  // quantities scale). Throws std::invalid_argument if the aspect ratio differs by more than a
  // pixel.
  MirrorModel scaledTo(int width, int height) const;

 private:
  MirrorParams params_;
  double sign_;  // +1 mirrored, -1 not
};

// What common code knows about one camera: image size, mirror and colour table preset name.
struct CameraModel {
  MirrorModel mirror{MirrorParams{}};
  // Colour table preset (config/camera/<name>.yaml).
  std::string colour_table = "colours_sim";
};

// Reads the `image` and `mirror` sections and the `colour_table` key of a camera preset (see
// config/camera/omni_sim.yaml). Other sections (render, pipeline) belong to the camera service;
// the caller calls root.rejectUnknownKeys() after reading them.
CameraModel loadCameraModel(const config::Node& root);
// Loads a camera preset by name ("omni_sim", "omni_sim_640") or path, accepting the service's
// sections without reading them.
CameraModel loadCameraPreset(const std::string& name_or_path);

}  // namespace fieldline::camera
