#include "services/region_tracking/detectors.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
#include <numbers>

namespace fieldline::region_tracking {

namespace {
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// Contour points are cell corners; pixel centres sit at integer coordinates, so the corner
// between pixels u-1 and u is at u - 0.5.
constexpr float kCornerToPixel = -0.5f;

// Nearest pixel coordinate; below -0.5 anything negative (outside the frame either way).
// Cheaper than std::lround, which is a library call.
inline int nearestPixel(float coordinate) {
  const float shifted = coordinate + 0.5f;
  return shifted < 0.0f ? -1 : static_cast<int>(shifted);
}
}  // namespace

// ---------------------------------------------------------------------------------------------

FloorLookup::FloorLookup(const camera::MirrorModel& mirror)
    : width_(mirror.width()),
      height_(mirror.height()),
      x_(static_cast<std::size_t>(width_) * height_, kNaN),
      y_(x_.size(), kNaN),
      finestMetresPerPixel_(x_.size(), kNaN) {
  for (int v = 0; v < height_; ++v) {
    for (int u = 0; u < width_; ++u) {
      if (mirror.dontTouch(u, v)) continue;
      const camera::Vec2 pixel(u, v);
      const std::optional<camera::Vec2> floor = mirror.imageToRobot(pixel);
      if (!floor) continue;
      const std::size_t i = static_cast<std::size_t>(v) * width_ + u;
      x_[i] = static_cast<float>(floor->x());
      y_[i] = static_cast<float>(floor->y());
      const camera::Vec2 mpp = mirror.metresPerPixel(pixel);
      finestMetresPerPixel_[i] = static_cast<float>(std::min(mpp.x(), mpp.y()));
    }
  }
}

std::optional<camera::Vec2> FloorLookup::floorPoint(double u, double v) const {
  const int u0 = static_cast<int>(std::floor(u));
  const int v0 = static_cast<int>(std::floor(v));
  if (u0 < 0 || v0 < 0 || u0 + 1 >= width_ || v0 + 1 >= height_) return std::nullopt;
  const double fu = u - u0;
  const double fv = v - v0;
  const std::size_t i = static_cast<std::size_t>(v0) * width_ + u0;
  const std::size_t corners[4] = {i, i + 1, i + width_, i + width_ + 1};
  const double weights[4] = {(1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv};
  double x = 0, y = 0;
  for (int k = 0; k < 4; ++k) {
    x += weights[k] * x_[corners[k]];
    y += weights[k] * y_[corners[k]];
  }
  if (!std::isfinite(x) || !std::isfinite(y)) return std::nullopt;
  return camera::Vec2(x, y);
}

// ---------------------------------------------------------------------------------------------

LineDetector::LineDetector(const camera::ColourTable& table, const FloorLookup& floor,
                           const LineDetectorParams& params, int cellSize)
    : table_(table), floor_(floor), params_(params), cellSize_(cellSize) {}

bool LineDetector::scan(const camera::FrameView& frame, float originU, float originV, float normalU,
                        float normalV, float& lineU, float& lineV) {
  const int ou = nearestPixel(originU);
  const int ov = nearestPixel(originV);
  if (!frame.contains(ou, ov)) return false;
  const float metresPerPixel = floor_.finestMetresPerPixel(ou, ov);
  if (!std::isfinite(metresPerPixel)) return false;
  // Boundaries along the edge of the view face unusable pixels: nothing to find there.
  const int pu = nearestPixel(originU + normalU * (cellSize_ + 1));
  const int pv = nearestPixel(originV + normalV * (cellSize_ + 1));
  if (!frame.contains(pu, pv) || !std::isfinite(floor_.finestMetresPerPixel(pu, pv))) {
    return false;
  }
  const int maxRun =
      static_cast<int>(params_.widthTolerance * params_.lineWidth / metresPerPixel) + 2;
  const int start = -cellSize_;
  const int stop = cellSize_ + maxRun + 2 * params_.maxTransitionPixels + 1;

  // Walk the normal pixel by pixel looking for: field ... [transition] line-run [transition]
  // field. Each sample keeps its position along the normal (the pixel centre projected on it)
  // and its brightness, for the sub-pixel edges below.
  samples_.clear();
  bool sawField = false;
  int lastField = -1, runStart = -1, runEnd = -1, transition = 0;
  int previousU = INT32_MIN, previousV = INT32_MIN;
  for (int t = start; t <= stop; ++t) {
    const int u = nearestPixel(originU + normalU * t);
    const int v = nearestPixel(originV + normalV * t);
    if (u == previousU && v == previousV) continue;
    previousU = u;
    previousV = v;
    if (!frame.contains(u, v)) return false;
    const camera::Yuv yuv = camera::readYuv(frame, u, v);
    ++pixelsRead_;
    const camera::ColourClass c = table_.classifyYuv(yuv);
    const int index = static_cast<int>(samples_.size());
    samples_.push_back({(u - originU) * normalU + (v - originV) * normalV, yuv.y});
    const bool field = c == params_.fieldColour;
    const bool line = c == params_.lineColour;
    if (runStart < 0) {  // before the line
      if (field) {
        sawField = true;
        lastField = index;
        transition = 0;
      } else if (line) {
        if (!sawField) return false;
        runStart = runEnd = index;
        transition = 0;
      } else if (sawField && ++transition > params_.maxTransitionPixels) {
        return false;
      }
    } else if (line && runEnd == index - 1) {  // on the line
      runEnd = index;
      if (runEnd - runStart + 1 > maxRun) return false;
    } else if (field) {  // back on the field: found
      const float middle =
          0.5f * (risingEdge(lastField, runStart, runEnd) + fallingEdge(runStart, runEnd, index));
      lineU = originU + normalU * middle;
      lineV = originV + normalV * middle;
      return true;
    } else if (line || ++transition > params_.maxTransitionPixels) {
      return false;
    }
  }
  return false;
}

// Where the brightness crosses halfway between the field before the line and the line's
// brightest sample, interpolated between the two samples around the crossing.
float LineDetector::risingEdge(int field, int runStart, int runEnd) const {
  std::uint8_t peak = 0;
  for (int i = runStart; i <= runEnd; ++i)
    peak = std::max(peak, samples_[i].luma);
  const float threshold = 0.5f * (static_cast<float>(samples_[field].luma) + peak);
  for (int i = field; i < runStart; ++i) {
    const Sample& a = samples_[i];
    const Sample& b = samples_[i + 1];
    if (a.luma < threshold && b.luma >= threshold) {
      return a.t + (b.t - a.t) * (threshold - a.luma) / (static_cast<float>(b.luma) - a.luma);
    }
  }
  return 0.5f * (samples_[runStart - 1].t + samples_[runStart].t);
}

float LineDetector::fallingEdge(int runStart, int runEnd, int field) const {
  std::uint8_t peak = 0;
  for (int i = runStart; i <= runEnd; ++i)
    peak = std::max(peak, samples_[i].luma);
  const float threshold = 0.5f * (static_cast<float>(samples_[field].luma) + peak);
  for (int i = runEnd; i < field; ++i) {
    const Sample& a = samples_[i];
    const Sample& b = samples_[i + 1];
    if (a.luma >= threshold && b.luma < threshold) {
      return a.t + (b.t - a.t) * (a.luma - threshold) / (a.luma - static_cast<float>(b.luma));
    }
  }
  return 0.5f * (samples_[runEnd].t + samples_[runEnd + 1].t);
}

void LineDetector::detect(const camera::FrameView& frame, const ContourSet& contours,
                          LinePoints& out) {
  out.clear();
  pixelsRead_ = 0;
  const ClassId field = classIdOf(params_.fieldColour);
  for (const Contour& contour : contours.contours) {
    if (contour.classId != field || contour.size() < params_.minContourPoints) continue;
    const int n = contour.size();
    smoothU_.resize(n);
    smoothV_.resize(n);
    tmpU_.resize(n);
    tmpV_.resize(n);
    for (int i = 0; i < n; ++i) {
      const ContourPoint& p = contours.points[contour.begin + i];
      smoothU_[i] = static_cast<float>(p.x) + kCornerToPixel;
      smoothV_[i] = static_cast<float>(p.y) + kCornerToPixel;
    }
    // The contour is a staircase of cell sides; smoothing turns it into a curve with usable
    // tangents (the seed smooths before taking differences, section 3.3).
    for (int pass = 0; pass < params_.smoothingPasses; ++pass) {
      for (int i = 0; i < n; ++i) {
        const int prev = i == 0 ? n - 1 : i - 1;
        const int next = i == n - 1 ? 0 : i + 1;
        tmpU_[i] = 0.25f * smoothU_[prev] + 0.5f * smoothU_[i] + 0.25f * smoothU_[next];
        tmpV_[i] = 0.25f * smoothV_[prev] + 0.5f * smoothV_[i] + 0.25f * smoothV_[next];
      }
      smoothU_.swap(tmpU_);
      smoothV_.swap(tmpV_);
    }

    const int samples = n / params_.sampleSpacing;
    hits_.assign(samples, Hit{false, {}});
    const int k = params_.tangentHalfSpan;
    for (int s = 0; s < samples; ++s) {
      const int i = s * params_.sampleSpacing;
      const int ahead = (i + k) % n;
      const int behind = (i - k + n) % n;
      float tu = smoothU_[ahead] - smoothU_[behind];
      float tv = smoothV_[ahead] - smoothV_[behind];
      const float length = std::sqrt(tu * tu + tv * tv);
      if (length < 1e-3f) continue;
      tu /= length;
      tv /= length;
      // The region lies to the right of the walking direction on screen: outward is left.
      const float normalU = tv;
      const float normalV = -tu;
      float lineU = 0, lineV = 0;
      if (!scan(frame, smoothU_[i], smoothV_[i], normalU, normalV, lineU, lineV)) continue;
      const std::optional<camera::Vec2> floor = floor_.floorPoint(lineU, lineV);
      if (!floor) continue;
      hits_[s] = {true,
                  {lineU, lineV, static_cast<float>(floor->x()), static_cast<float>(floor->y())}};
    }

    // Group hits into sequences along the contour, starting after a miss so that a sequence
    // crossing the contour's start is not cut in two.
    int firstMiss = -1;
    for (int s = 0; s < samples && firstMiss < 0; ++s) {
      if (!hits_[s].found) firstMiss = s;
    }
    const int begin = firstMiss < 0 ? 0 : firstMiss;
    int sequenceStart = -1;
    int misses = 0;
    auto close = [&] {
      const int end = static_cast<int>(out.points.size());
      if (sequenceStart >= 0 && end - sequenceStart >= 2) {
        out.sequences.emplace_back(sequenceStart, end);
      } else if (sequenceStart >= 0) {
        out.points.resize(sequenceStart);  // a lone point is more likely noise than a line
      }
      sequenceStart = -1;
    };
    for (int step = 0; step < samples; ++step) {
      const Hit& hit = hits_[(begin + step) % samples];
      if (hit.found) {
        if (sequenceStart < 0) sequenceStart = static_cast<int>(out.points.size());
        out.points.push_back(hit.point);
        misses = 0;
      } else if (sequenceStart >= 0 && ++misses > params_.maxGapSamples) {
        close();
      }
    }
    close();
  }
}

// ---------------------------------------------------------------------------------------------

BallDetector::BallDetector(const camera::ColourTable& table, const camera::MirrorModel& mirror,
                           const BallParams& params)
    : table_(table), mirror_(mirror), params_(params) {}

BallDetection BallDetector::detect(const camera::FrameView& frame,
                                   const ContourSet& contours) const {
  BallDetection ball;
  const ClassId orange = classIdOf(params_.colour);
  const Contour* best = nullptr;
  for (const Contour& contour : contours.contours) {
    if (contour.classId == orange && contour.outer &&
        (best == nullptr || contour.signedCellArea > best->signedCellArea)) {
      best = &contour;
    }
  }
  if (best == nullptr) return ball;

  // The ball is a sphere seen from the mirror's reference point R: its image stretches
  // radially from the ray grazing its near side to the ray grazing its far side, and the ray to
  // its centre halves the angle between those two (seed 4.9.5). So take the nearest and
  // farthest orange pixel radius (the centroid would be pulled outward), and the bearing from
  // the centroid of the orange pixels.
  int minU = frame.width, minV = frame.height, maxU = 0, maxV = 0;
  for (const ContourPoint& p : contours.pointsOf(*best)) {
    minU = std::min(minU, p.x);
    maxU = std::max(maxU, p.x);
    minV = std::min(minV, p.y);
    maxV = std::max(maxV, p.y);
  }
  minU = std::max(0, minU - 1);
  minV = std::max(0, minV - 1);
  maxU = std::min(frame.width, maxU + 1);
  maxV = std::min(frame.height, maxV + 1);
  const camera::Vec2 centre = mirror_.params().centre;
  double sumU = 0, sumV = 0;
  double nearRadius = std::numeric_limits<double>::infinity(), farRadius = 0;
  int pixels = 0;
  for (int v = minV; v < maxV; ++v) {
    for (int u = minU; u < maxU; ++u) {
      if (table_.classifyPixel(frame, u, v) != params_.colour) continue;
      sumU += u;
      sumV += v;
      ++pixels;
      const double radius = std::hypot(u - centre.x(), v - centre.y());
      nearRadius = std::min(nearRadius, radius);
      farRadius = std::max(farRadius, radius);
    }
  }
  if (pixels < params_.minPixels) return ball;
  const camera::Vec2 centroid(sumU / pixels, sumV / pixels);
  const double bearing = mirror_.bearingOf(centroid);
  const camera::DistanceFunction& distance = mirror_.params().distance;
  // Half a pixel beyond the outermost pixel centres on both sides.
  const double nearFloor = distance.floorDistance(std::max(0.0, nearRadius - 0.5), bearing);
  const double farFloor = distance.floorDistance(farRadius + 0.5, bearing);
  if (!std::isfinite(nearFloor) || !std::isfinite(farFloor)) return ball;
  const double H = mirror_.params().reference_height;
  // Depression angles of the two grazing rays from R; the centre ray lies midway.
  const double centreAngle = 0.5 * (std::atan2(H, nearFloor) + std::atan2(H, farFloor));
  const double centreFloor = H / std::tan(centreAngle);
  const double lift = (H - params_.centreHeight) / H;
  const double horizontal = centreFloor * lift;
  const camera::Vec2 direction = camera::Vec2(std::cos(bearing), std::sin(bearing));
  const camera::Vec2 centreXY = direction * horizontal;
  const std::optional<camera::Vec2> centrePixel = mirror_.robotToImage(direction * centreFloor);
  if (!centrePixel) return ball;

  ball.visible = true;
  ball.u = centrePixel->x();
  ball.v = centrePixel->y();
  ball.x = centreXY.x();
  ball.y = centreXY.y();
  ball.pixels = pixels;
  ball.cells = best->signedCellArea;
  // Half a pixel of centroid error, scaled to the floor and lifted to the ball's height.
  const camera::Vec2 mpp = mirror_.metresPerPixel(*centrePixel);
  ball.sigmaRadial = 0.5 * mpp.x() * lift;
  ball.sigmaTangential = 0.5 * mpp.y() * lift;
  // The blob should be about as wide (across the ray) as the ball: a too narrow one is
  // probably a partly hidden ball or an orange speck.
  const double expectedWidthPx = 2 * params_.centreHeight / lift / mpp.y();
  const double radialPx = farRadius - nearRadius + 1;
  ball.confidence = std::clamp(
      pixels / std::max(radialPx * expectedWidthPx * std::numbers::pi / 4, 1.0), 0.0, 1.0);
  return ball;
}

// ---------------------------------------------------------------------------------------------

ObstacleDetector::ObstacleDetector(const camera::MirrorModel& mirror, const ObstacleParams& params)
    : mirror_(mirror), params_(params) {}

void ObstacleDetector::detect(const ContourSet& contours, std::vector<Obstacle>& out) const {
  out.clear();
  const ClassId black = classIdOf(params_.colour);
  for (const Contour& contour : contours.contours) {
    if (contour.classId != black || !contour.outer || contour.signedCellArea < params_.minCells) {
      continue;
    }
    // The foot of an object standing on the floor is its point nearest the image centre;
    // its angular extent is the spread of bearings around the first point.
    camera::Vec2 nearest;
    double nearestRadius = std::numeric_limits<double>::infinity();
    double firstBearing = 0, minOffset = 0, maxOffset = 0;
    bool first = true;
    for (const ContourPoint& p : contours.pointsOf(contour)) {
      const camera::Vec2 pixel(p.x + kCornerToPixel, p.y + kCornerToPixel);
      const double bearing = mirror_.bearingOf(pixel);
      if (first) {
        firstBearing = bearing;
        first = false;
      }
      const double offset = std::remainder(bearing - firstBearing, 2 * std::numbers::pi);
      minOffset = std::min(minOffset, offset);
      maxOffset = std::max(maxOffset, offset);
      const double radius = mirror_.radiusOf(pixel);
      if (radius < nearestRadius) {
        nearestRadius = radius;
        nearest = pixel;
      }
    }
    const std::optional<camera::Vec2> foot = mirror_.imageToRobot(nearest);
    if (!foot) continue;
    Obstacle obstacle;
    obstacle.distance = foot->norm();
    obstacle.x = foot->x();
    obstacle.y = foot->y();
    obstacle.angularWidth = maxOffset - minOffset;
    obstacle.bearing =
        std::remainder(firstBearing + 0.5 * (minOffset + maxOffset), 2 * std::numbers::pi);
    obstacle.width = 2.0 * obstacle.distance * std::tan(0.5 * obstacle.angularWidth);
    out.push_back(obstacle);
  }
}

}  // namespace fieldline::region_tracking
