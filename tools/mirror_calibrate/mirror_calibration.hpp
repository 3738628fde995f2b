// Mirror calibration (issue 12, part 3; docs/mirror_calibration.md): from an image of bright
// rings laid on the floor at known distances around the robot's centre, find the mirror centre in
// the image, the offset between the mirror axis and the robot's centre, and the distance function
// (a table per bearing sector), with the residuals per sector. A plain library: no bus, no clock.
//
// Stages (each unit-tested):
//   1. findRingPeaks: along rays from a centre guess, the sub-pixel radii of bright ridges
//      (brighter than the floor on both sides within a window).
//   2. ringRadii: the radii where many rays have a peak (modes of a histogram), innermost first.
//   3. matchRings: which visible ring is which distance. Rings are ordered outward; when more or
//      fewer rings are visible than distances are given, the alignment whose radii a smooth
//      mirror law fits best wins.
//   4. fitRings: centre C, axis offset o and the radii rho_k of the distances d_k, jointly, by
//      robust Gauss-Newton (Huber weights, then outliers dropped). A ring point at axis bearing b
//      lies at axis-frame distance t with |t u(b) + o| = d_k, i.e. t = -(o.u) + sqrt((o.u)^2 -
//      |o|^2 + d_k^2), and at image radius R(t), R the monotone cubic through (0, 0) and
//      (d_k, rho_k). A centre error shifts all rings by the same pixels, an offset by the same
//      metres: the mirror's growing metres per pixel tells them apart.
//   5. sectorTable: with C and o fixed, each bearing sector gets its own curve through the median
//      radii of its ring points (a mirror that is not quite round), sampled on common radii into
//      the camera's table; residuals of every ring point against the finished table, per sector.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "tools/calibration_common/grey_image.hpp"

namespace fieldline::calibration {

using camera::Vec2;

// Residuals of a state; false when the state is not valid (e.g. knots out of order).
using ResidualFunction = std::function<bool(const Eigen::VectorXd&, Eigen::VectorXd&)>;
// Levenberg-Marquardt with Huber weights (threshold `huber`) and a numeric Jacobian (step
// steps[k] for parameter k; 0 holds it fixed). A step that makes `f` fail (an invalid state) is
// treated as a worse one. Throws std::invalid_argument when the start is not valid.
Eigen::VectorXd levenbergMarquardt(Eigen::VectorXd x, const ResidualFunction& f,
                                   const std::vector<double>& steps, double huber, int iterations);

// A monotone cubic (Fritsch-Carlson) through knots with strictly increasing x and
// non-decreasing y; linear beyond the ends (with the end slopes). Throws std::invalid_argument
// for fewer than two knots or unordered x.
class MonotoneCurve {
 public:
  MonotoneCurve(std::vector<double> x, std::vector<double> y);
  double operator()(double x) const;

 private:
  std::vector<double> x_, y_, slope_;
};

struct RingSearchParams {
  // Rays, evenly spaced around the centre.
  int rays = 360;
  // Radii searched, px (the robot's own reflection and the mirror's edge excluded).
  double min_radius = 20.0;
  double max_radius = 150.0;
  // Sampling step along a ray, px.
  double step = 0.25;
  // The floor on each side of a ridge is the darkest sample within this distance, px.
  double window = 5.0;
  // A ridge must be this many grey levels brighter than the brighter of its two sides.
  double min_contrast = 18.0;
};

struct RingPeak {
  int ray = 0;
  // Distance from the search centre, px, sub-pixel (brightness-weighted over the ridge).
  double radius = 0.0;
  double contrast = 0.0;
  Vec2 pixel = Vec2::Zero();
};

// Stage 1: bright ridges along `params.rays` rays from `centre`, innermost first per ray.
std::vector<RingPeak> findRingPeaks(const GreyImage& image, const Vec2& centre,
                                    const RingSearchParams& params);

// Stage 2: rings traced outward. The innermost ring is the circle through the first peak of each
// ray (robustly fitted, points more than 2 px off dropped); each further ring is the circle
// through the first peaks at least `gap` px beyond the previous ring's circle. Stops when fewer
// than `min_share` of the rays have a point on the next circle.
struct TracedRing {
  Vec2 centre = Vec2::Zero();
  double radius = 0.0;
  std::vector<Vec2> pixels;  // its peaks, outliers dropped
};
std::vector<TracedRing> traceRings(const std::vector<RingPeak>& peaks, int rays, const Vec2& centre,
                                   double min_share = 0.3, double gap = 1.0);

struct RingMatch {
  // rings[first_ring + i] is distances[first_distance + i] for i < count.
  int first_ring = 0;
  int first_distance = 0;
  int count = 0;
  // RMS of the relative misfit of a cubic d(r) through the origin, for the chosen alignment.
  double misfit = 0.0;
};
// Stage 3. `distances` increasing, > 0 (m). Throws std::invalid_argument if fewer than 4 rings
// can be matched.
RingMatch matchRings(const std::vector<double>& radii, const std::vector<double>& distances);

// A ring pixel and the index of its distance.
struct RingPoint {
  Vec2 pixel = Vec2::Zero();
  int ring = 0;
};

struct RingFitParams {
  // Fit the axis offset (else it stays zero).
  bool fit_offset = true;
  // Huber threshold, px; points beyond max(outlier_px, 4 robust sigma) are dropped.
  double huber_px = 0.5;
  double outlier_px = 1.5;
  int iterations = 30;
};

struct RingFit {
  Vec2 centre = Vec2::Zero();
  Vec2 axis_offset = Vec2::Zero();
  // rho_k: the image radius at axis-frame distance distances[k], px.
  std::vector<double> distances;
  std::vector<double> radii;
  double rms_px = 0.0;
  int inliers = 0;
  int outliers = 0;
  std::vector<bool> inlier;  // per point given to fitRings

  // Image radius at axis-frame distance `distance` (the curve through (0, 0) and the knots).
  double radiusAt(double distance) const;
  // Where ring `ring` appears along axis bearing `bearing` (image radius, px).
  double ringRadius(int ring, double bearing) const;
};

// Axis-frame bearing of a pixel seen from `centre` (the MirrorModel's convention).
double axisBearing(const Vec2& pixel, const Vec2& centre, double heading_angle, bool mirrored);
// Axis-frame distance to ring `distance` (m, around the robot's centre) along axis bearing
// `bearing` for an axis offset `offset`; NaN if the ray misses the ring.
double axisDistanceToRing(double distance, double bearing, const Vec2& offset);

// Stage 4. `base` gives heading_angle and mirrored; `start` the first centre guess and radii.
RingFit fitRings(const std::vector<RingPoint>& points, const std::vector<double>& distances,
                 const camera::MirrorParams& base, const Vec2& start_centre,
                 const std::vector<double>& start_radii, const RingFitParams& params);

struct SectorResidual {
  double bearing = 0.0;  // rad, axis frame
  int points = 0;
  int rings = 0;  // rings with points in this sector
  double rms_px = 0.0;
  double rms_percent = 0.0;  // distance error of the finished table, % of the true distance
  double max_percent = 0.0;
  double max_cm = 0.0;
};

struct SectorTable {
  camera::CalibrationTableParams table;
  std::vector<SectorResidual> residuals;
  // Over all inlier points.
  SectorResidual total;
};

// Stage 5. `sectors` >= 1; table radii every `radius_step` px up to the smallest outermost ring
// radius over the sectors.
SectorTable sectorTable(const RingFit& fit, const std::vector<RingPoint>& points,
                        const camera::MirrorParams& base, int sectors, double radius_step);

struct RingCalibrationParams {
  RingSearchParams search;
  RingFitParams fit;
  int sectors = 8;
  double radius_step = 2.0;
  // Rounds of (resample around the fitted centre, reassign, refit).
  int rounds = 3;
};

struct RingCalibration {
  std::vector<double> distances;  // the matched distances, m
  RingMatch match;
  std::vector<double> found_radii;  // stage 2 circle radii, px
  std::vector<RingPoint> points;    // the last round's assigned points
  RingFit fit;
  SectorTable table;
  // `base` with the fitted centre, offset, table, and useful_radius clipped to the table.
  camera::MirrorParams mirror;
};

// Stages 1-5 on one image. `base` gives the image size (must equal the image's), the heading,
// `mirrored`, the radii and reference height; its centre is the first guess. Throws
// std::invalid_argument with what went wrong (no rings, too few matched, a fit that does not
// converge to increasing radii).
RingCalibration calibrateFromRings(const GreyImage& image, const std::vector<double>& distances,
                                   const camera::MirrorParams& base,
                                   const RingCalibrationParams& params);

// Calibration from field lines (poses known or not): pose_free.hpp.

struct PosedImage {
  GreyImage image;
  geometry::Pose2 pose;  // the robot's centre in the field frame
};

// The camera preset (image, mirror with the table, colour_table, pipeline; no render section)
// as YAML text, loadable by services/camera/camera_config.
std::string cameraYaml(const camera::MirrorParams& mirror, const std::string& colour_table,
                       double frame_rate, double exposure, double latency,
                       const std::string& comment);

// Distances (m, > 0) from a ring list: "1,1.5,2" (m) or a CarpetCalibrator-style .conf
// (`distN = <mm>` lines; 0 is the centre and skipped). Throws std::invalid_argument.
std::vector<double> parseDistances(const std::string& text_or_path);

}  // namespace fieldline::calibration
