#include "services/region_tracking/ball_detector.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <vector>

#include "services/region_tracking/frame_classifier.hpp"

namespace fieldline::region_tracking {

BallDetector::BallDetector(const camera::ColourTable& table, const camera::MirrorModel& mirror,
                           const BallParams& params)
    : table_(table), mirror_(mirror), params_(params) {
  if (!(params_.size_tolerance >= 1.0) || !(params_.size_slack_px >= 0.0) ||
      !(params_.min_fill >= 0.0 && params_.min_fill <= 1.0) ||
      !(params_.min_carpet_share >= 0.0 && params_.min_carpet_share <= 1.0) ||
      !(params_.centre_height > 0.0 &&
        params_.centre_height < 0.5 * mirror_.params().reference_height) ||
      params_.min_pixels < 1) {
    throw std::invalid_argument("ball detector: invalid parameters");
  }
  // The ball is largest in the image next to the robot: the largest extent of a ball at the
  // edge of the robot's own reflection and a little beyond, in a few directions.
  const double nearest = mirror_.params().distance.floorDistance(
      mirror_.params().self_radius, 0.0);  // floor distance at the self radius
  for (int k = 0; k < 8; ++k) {
    const double bearing = k * std::numbers::pi / 4;
    for (double d = std::max(nearest, 0.0) + params_.centre_height; d < 2.0; d += 0.05) {
      double radial = 0, tangential = 0;
      if (expectedExtent(d, bearing, radial, tangential)) {
        max_extent_px_ = std::max({max_extent_px_, radial, tangential});
      }
    }
  }
  if (max_extent_px_ <= 0) throw std::invalid_argument("ball detector: no ball is visible");
  insets_ = edgeInsetTableFor(mirror_, params_.centre_height);
  const std::vector<camera::ColourClass>& cells = table_.yuvLookup();
  has_colour_ = std::find(cells.begin(), cells.end(), params_.colour) != cells.end();
}

bool BallDetector::expectedExtent(double horizontal, double bearing, double& radialPx,
                                  double& tangentialPx) const {
  // Every point of the sphere projects inside its silhouette and the silhouette's rim is made of
  // sphere points: the extents of the projected surface points are the silhouette's.
  const double r = params_.centre_height;
  // `horizontal` and `bearing` are about the mirror axis; the 3-D projection takes robot-frame
  // points.
  const camera::Vec2 xy =
      mirror_.axisToRobot(horizontal * camera::Vec2(std::cos(bearing), std::sin(bearing)));
  const camera::Vec3 centre(xy.x(), xy.y(), r);
  const std::optional<camera::Vec2> centrePixel = mirror_.robotPointToImage(centre);
  if (!centrePixel) return false;
  const double centreBearing = mirror_.bearingOf(*centrePixel);
  const double centreRadius = mirror_.radiusOf(*centrePixel);
  double nearR = std::numeric_limits<double>::infinity(), farR = 0, minOff = 0, maxOff = 0;
  constexpr int kPolar = 8, kAzimuth = 16;
  for (int i = 0; i <= kPolar; ++i) {
    const double theta = std::numbers::pi * i / kPolar;
    for (int j = 0; j < (i == 0 || i == kPolar ? 1 : kAzimuth); ++j) {
      const double phi = 2 * std::numbers::pi * j / kAzimuth;
      const camera::Vec3 p =
          centre + r * camera::Vec3(std::sin(theta) * std::cos(phi),
                                    std::sin(theta) * std::sin(phi), std::cos(theta));
      const std::optional<camera::Vec2> pixel = mirror_.robotPointToImage(p);
      if (!pixel) return false;
      const double radius = mirror_.radiusOf(*pixel);
      nearR = std::min(nearR, radius);
      farR = std::max(farR, radius);
      const double offset =
          std::remainder(mirror_.bearingOf(*pixel) - centreBearing, 2 * std::numbers::pi);
      minOff = std::min(minOff, offset);
      maxOff = std::max(maxOff, offset);
    }
  }
  radialPx = farR - nearR;
  tangentialPx = (maxOff - minOff) * centreRadius;
  return true;
}

namespace {
// An outermost orange pixel this close to the useful radius (px; the tracked regions end in
// whole cells) may be where the measured zone ends, not the ball.
constexpr double kFarEdgeReachPx = 3.0;
// The depression angle of the ray from R to the centre of a ball (centre `height` up, R at
// `H`) whose near grazing ray has depression `nearAngle`: asin(radius / distance to the centre)
// above it.
double nearOnlyAngle(double nearAngle, double H, double height) {
  double angle = nearAngle;
  for (int i = 0; i < 8; ++i) {
    angle = nearAngle - std::asin(std::min(1.0, height * std::sin(angle) / (H - height)));
  }
  return angle;
}
// How well a measured extent agrees with the expected one, in (0, 1].
double agreement(double measured, double expected) {
  return (std::min(measured, expected) + 1.0) / (std::max(measured, expected) + 1.0);
}
}  // namespace

BallReject BallDetector::boxOf(const camera::FrameView& frame, const ContourSet& contours,
                               const Contour& contour, PixelBox& box) const {
  int minU = frame.width, minV = frame.height, maxU = 0, maxV = 0;
  for (const ContourPoint& p : contours.pointsOf(contour)) {
    minU = std::min(minU, p.x);
    maxU = std::max(maxU, p.x);
    minV = std::min(minV, p.y);
    maxV = std::max(maxV, p.y);
  }
  // The region's box is in whole cells; a ball's image is never much larger than the largest
  // ball image plus a cell on each side.
  const double largest = max_extent_px_ * params_.size_tolerance + params_.size_slack_px + 8.0;
  if (maxU - minU > largest || maxV - minV > largest) return BallReject::kTooLarge;
  // Cut by the image's border: its size says nothing (a cut box can look like a ball).
  if (minU <= 0 || minV <= 0 || maxU >= frame.width || maxV >= frame.height) {
    return BallReject::kAtImageBorder;
  }
  box.min_u = std::max(0, minU - 1);
  box.min_v = std::max(0, minV - 1);
  box.max_u = std::min(frame.width, maxU + 1);
  box.max_v = std::min(frame.height, maxV + 1);
  return BallReject::kNone;
}

BallDetector::BallPixels BallDetector::ballPixels(const camera::FrameView& frame,
                                                  const PixelBox& box) const {
  // The ball is a sphere seen from the mirror's reference point R: its image stretches
  // radially from the ray grazing its near side to the ray grazing its far side, and the ray to
  // its centre halves the angle between those two (seed 4.9.5). So take the nearest and
  // farthest orange pixel radius (the centroid would be pulled outward), and the bearing from
  // the centroid of the orange pixels.
  const camera::Vec2 centre = mirror_.params().centre;
  BallPixels pixels;
  pixels.near_radius = std::numeric_limits<double>::infinity();
  for (int v = box.min_v; v < box.max_v; ++v) {
    for (int u = box.min_u; u < box.max_u; ++u) {
      if (table_.classifyPixel(frame, u, v) != params_.colour) continue;
      pixels.sum_u += u;
      pixels.sum_v += v;
      ++pixels.count;
      const double radius = std::hypot(u - centre.x(), v - centre.y());
      pixels.near_radius = std::min(pixels.near_radius, radius);
      pixels.far_radius = std::max(pixels.far_radius, radius);
    }
  }
  return pixels;
}

BallReject BallDetector::place(const BallPixels& pixels, const BallRegion* region, bool yuyv,
                               BallPlace& out) const {
  out.centroid = camera::Vec2(pixels.sum_u / pixels.count, pixels.sum_v / pixels.count);
  const double bearing = mirror_.bearingOf(out.centroid);
  const camera::DistanceFunction& distance = mirror_.params().distance;
  // Half a pixel beyond the outermost pixel centres on both sides (the floor must be seen there).
  const double nearFloor = distance.floorDistance(std::max(0.0, pixels.near_radius - 0.5), bearing);
  const double farFloor = distance.floorDistance(pixels.far_radius + 0.5, bearing);
  if (!std::isfinite(nearFloor) || !std::isfinite(farFloor)) return BallReject::kNoFloor;
  const double H = mirror_.params().reference_height;
  out.lift = (H - params_.centre_height) / H;
  // When the outermost orange pixel lies at the end of the measured zone (useful_radius), the
  // image ends there and not the ball: its far edge is unknown, and the midway ray would put the
  // ball short (15-35 cm at 4.5-5.5 m in omni_sim). Then the centre ray comes from the near
  // grazing ray alone.
  out.far_edge_cut = false;
  if (pixels.far_radius + kFarEdgeReachPx >= mirror_.params().useful_radius) {
    const double nearOnly = nearOnlyAngle(std::atan2(H, nearFloor), H, params_.centre_height);
    // Cut: a ball there would reach more than a pixel further out than the orange pixels do.
    double spanRadial = 0, spanTangential = 0;
    if (expectedExtent(H / std::tan(nearOnly) * out.lift, bearing, spanRadial, spanTangential) &&
        pixels.far_radius - pixels.near_radius + 1.0 < spanRadial - 1.0) {
      out.far_edge_cut = true;
    }
  }
  // The silhouette's edges lie beyond the outermost pixels by the insets of a ball at that
  // place; a first place with half a pixel at each edge tells which insets.
  // (Where the moved far edge lies beyond a calibration table's last radius, the first place
  // stays.)
  double angle = centreAngle(pixels, bearing, EdgeInsets{}, out.far_edge_cut);
  if (!std::isfinite(angle)) return BallReject::kNoFloor;
  const double refined = centreAngle(
      pixels, bearing, edgeInsets(H / std::tan(angle) * out.lift, bearing, yuyv), out.far_edge_cut);
  if (std::isfinite(refined)) angle = refined;
  const double centreFloor = H / std::tan(angle);
  out.bearing = bearing;
  out.horizontal = centreFloor * out.lift;
  // All of this is about the mirror axis (its rays start there): move to the robot frame last.
  const camera::Vec2 direction = camera::Vec2(std::cos(bearing), std::sin(bearing));
  out.centre_xy = mirror_.axisToRobot(direction * out.horizontal);
  const std::optional<camera::Vec2> centrePixel = mirror_.axisToImage(direction * centreFloor);
  if (!centrePixel) return BallReject::kNoFloor;
  out.centre_pixel = *centrePixel;
  // Where the field model says a ball can be: on the field, seen from fusion's pose.
  if (region && region->field) {
    const geometry::Vec2 onField = geometry::pointRobotToField(region->pose, out.centre_xy);
    if (!region->field->insideLines(onField, params_.field_margin_m + region->pose_sigma_m)) {
      return BallReject::kOutsideField;
    }
  }
  return BallReject::kNone;
}

double BallDetector::centreAngle(const BallPixels& pixels, double bearing, const EdgeInsets& insets,
                                 bool farCut) const {
  // Depression angles of the two grazing rays from R; the ray to the centre lies midway (seed
  // 4.9.5), or with the far edge cut asin(radius / distance to the centre) above the near one.
  const camera::DistanceFunction& distance = mirror_.params().distance;
  const double H = mirror_.params().reference_height;
  const double nearAngle = std::atan2(
      H, distance.floorDistance(std::max(0.0, pixels.near_radius - insets.near_px), bearing));
  if (farCut) return nearOnlyAngle(nearAngle, H, params_.centre_height);
  const double farAngle =
      std::atan2(H, distance.floorDistance(pixels.far_radius + insets.far_px, bearing));
  return 0.5 * (nearAngle + farAngle);
}

BallReject BallDetector::checkShape(const camera::FrameView& frame, const PixelBox& box,
                                    const BallPixels& pixels, const BallPlace& place,
                                    BallShape& out) const {
  // What a ball there would look like (3-D mirror model) against the pixels.
  if (!expectedExtent(place.horizontal, place.bearing, out.expected_radial,
                      out.expected_tangential)) {
    return BallReject::kNoFloor;
  }
  double minOffset = 0, maxOffset = 0;
  for (int v = box.min_v; v < box.max_v; ++v) {
    for (int u = box.min_u; u < box.max_u; ++u) {
      if (table_.classifyPixel(frame, u, v) != params_.colour) continue;
      const double offset = std::remainder(mirror_.bearingOf(camera::Vec2(u, v)) - place.bearing,
                                           2 * std::numbers::pi);
      minOffset = std::min(minOffset, offset);
      maxOffset = std::max(maxOffset, offset);
    }
  }
  // Extents over pixel centres, plus the pixel itself.
  out.radial_px = pixels.far_radius - pixels.near_radius + 1;
  out.tangential_px = (maxOffset - minOffset) * mirror_.radiusOf(place.centroid) + 1;
  const double tol = params_.size_tolerance, slack = params_.size_slack_px;
  auto fits = [&](double measured, double expected) {
    return measured <= expected * tol + slack && measured >= expected / tol - slack;
  };
  if (!fits(out.radial_px, out.expected_radial) ||
      !fits(out.tangential_px, out.expected_tangential)) {
    return BallReject::kSize;
  }
  const double silhouette =
      std::numbers::pi / 4 * (out.expected_radial + 1) * (out.expected_tangential + 1);
  out.fill = pixels.count / silhouette;
  if (out.fill < params_.min_fill) return BallReject::kFill;
  return BallReject::kNone;
}

bool BallDetector::onCarpet(const camera::FrameView& frame, const camera::Vec2& centroid,
                            const BallShape& shape, double& carpetShare) const {
  // A ring of samples around the candidate, 1.5 times its expected size + 2 px.
  const camera::Vec2 radialAxis = (centroid - mirror_.params().centre).normalized();
  const camera::Vec2 tangentialAxis(-radialAxis.y(), radialAxis.x());
  const double ringRadial = 0.75 * shape.expected_radial + 2.0;
  const double ringTangential = 0.75 * shape.expected_tangential + 2.0;
  constexpr int kRingSamples = 16;
  int usable = 0, carpet = 0;
  for (int k = 0; k < kRingSamples; ++k) {
    const double a = 2 * std::numbers::pi * k / kRingSamples;
    const camera::Vec2 p = centroid + radialAxis * (std::cos(a) * ringRadial) +
                           tangentialAxis * (std::sin(a) * ringTangential);
    const int u = static_cast<int>(std::lround(p.x())), v = static_cast<int>(std::lround(p.y()));
    if (!frame.contains(u, v) || mirror_.zone(camera::Vec2(u, v)) == camera::MirrorZone::kSelf ||
        mirror_.zone(camera::Vec2(u, v)) == camera::MirrorZone::kOutside) {
      continue;  // no floor to see there (the robot's own reflection, outside the mirror)
    }
    ++usable;
    const camera::ColourClass c = table_.classifyPixel(frame, u, v);
    if (c == params_.field_colour || c == params_.line_colour) ++carpet;
  }
  carpetShare = usable > 0 ? static_cast<double>(carpet) / usable : 0.0;
  return usable >= kRingSamples / 2 && carpetShare >= params_.min_carpet_share;
}

BallReject BallDetector::evaluate(const camera::FrameView& frame, const ContourSet& contours,
                                  const Contour& contour, BallDetection& out,
                                  const BallRegion* region) const {
  out = BallDetection{};
  PixelBox box;
  if (const BallReject why = boxOf(frame, contours, contour, box); why != BallReject::kNone) {
    return why;
  }
  const BallPixels pixels = ballPixels(frame, box);
  if (pixels.count < params_.min_pixels) return BallReject::kTooFewPixels;
  BallPlace where;
  if (const BallReject why =
          place(pixels, region, frame.format == camera::PixelFormat::kYuyv, where);
      why != BallReject::kNone) {
    return why;
  }
  BallShape shape;
  if (const BallReject why = checkShape(frame, box, pixels, where, shape);
      why != BallReject::kNone) {
    return why;
  }
  double carpetShare = 0;
  if (!onCarpet(frame, where.centroid, shape, carpetShare)) return BallReject::kNotOnCarpet;

  out.visible = true;
  out.u = where.centre_pixel.x();
  out.v = where.centre_pixel.y();
  out.x = where.centre_xy.x();
  out.y = where.centre_xy.y();
  out.pixels = pixels.count;
  out.cells = contour.signed_cell_area;
  // Half a pixel of centroid error, scaled to the floor and lifted to the ball's height.
  const camera::Vec2 mpp = mirror_.metresPerPixel(where.centre_pixel);
  out.sigma_radial = 0.5 * mpp.x() * where.lift;
  if (where.far_edge_cut) {
    // The near edge alone: a whole pixel, the far edge no longer halves its error.
    out.sigma_radial = mpp.x() * where.lift;
  }
  out.sigma_tangential = 0.5 * mpp.y() * where.lift;
  out.confidence = carpetShare * std::min(shape.fill, 1.0) *
                   agreement(shape.radial_px, shape.expected_radial + 1) *
                   agreement(shape.tangential_px, shape.expected_tangential + 1);
  return BallReject::kNone;
}

BallDetection BallDetector::detect(const camera::FrameView& frame, const ContourSet& contours,
                                   const BallRegion* region) const {
  BallDetection best;
  int candidates = 0, rejected = 0;
  const ClassId orange = classIdOf(params_.colour);
  BallDetection candidate;
  for (const Contour& contour : contours.contours) {
    if (contour.class_id != orange || !contour.outer) continue;
    ++candidates;
    if (evaluate(frame, contours, contour, candidate, region) != BallReject::kNone) {
      ++rejected;
      continue;
    }
    if (!best.visible || candidate.confidence > best.confidence) best = candidate;
  }
  best.candidates = candidates;
  best.rejected = rejected;
  return best;
}

}  // namespace fieldline::region_tracking
