// Detectors that run on the region boundaries (seed 3.3): field lines along the normals of the
// green boundaries, the ball in orange regions next to green, obstacles in black regions next
// to green. They read single pixels of the raw frame and map image points to the robot frame
// through the mirror model.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "services/region_tracking/cell_grid.hpp"
#include "services/region_tracking/contours.hpp"
#include "services/region_tracking/frame_classifier.hpp"

namespace fieldline::region_tracking {

// Robot-frame floor point of every pixel, computed once, so that mapping a detection costs a
// bilinear lookup instead of the mirror's trigonometry.
class FloorLookup {
 public:
  explicit FloorLookup(const camera::MirrorModel& mirror);
  // Floor point (m, robot frame) at a sub-pixel image position; nullopt where any of the four
  // surrounding pixels has no usable floor point.
  std::optional<camera::Vec2> floorPoint(double u, double v) const;
  // Smaller of the radial and tangential floor sizes of the pixel, m (NaN where unusable): a
  // floor length L spans at most L / finestMetresPerPixel pixels there.
  float finestMetresPerPixel(int u, int v) const { return finestMetresPerPixel_[v * width_ + u]; }

 private:
  int width_;
  int height_;
  std::vector<float> x_;  // NaN where unusable
  std::vector<float> y_;
  std::vector<float> finestMetresPerPixel_;
};

struct LinePoint {
  // Image position, px (sub-pixel).
  float u = 0;
  float v = 0;
  // Floor position in the robot frame, m.
  float x = 0;
  float y = 0;
};

// Line points of one frame, grouped into sequences that follow a contour (seed 4.13.1).
struct LinePoints {
  std::vector<LinePoint> points;
  // [start, end) into points.
  std::vector<std::pair<int, int>> sequences;
  void clear() {
    points.clear();
    sequences.clear();
  }
};

struct LineDetectorParams {
  camera::ColourClass fieldColour = camera::ColourClass::kGreen;
  camera::ColourClass lineColour = camera::ColourClass::kWhite;
  // Width of the field lines, m: bounds the length of a white run along a normal.
  double lineWidth = 0.125;
  // A white run may be up to this many times the line's expected width in pixels (+ 2 px).
  double widthTolerance = 2.5;
  // Pixels of neither class allowed between green and white (blurred edges).
  int maxTransitionPixels = 2;
  // The detector runs at every n-th contour corner.
  int sampleSpacing = 2;
  // Passes of 0.25/0.5/0.25 smoothing of the contour before tangents are taken.
  int smoothingPasses = 3;
  // Tangent from the points this many corners before and after.
  int tangentHalfSpan = 2;
  // Contours with fewer corners are skipped (noise regions).
  int minContourPoints = 16;
  // Consecutive samples without a detection that still continue a sequence.
  int maxGapSamples = 1;
};

class LineDetector {
 public:
  LineDetector(const camera::ColourTable& table, const FloorLookup& floor,
               const LineDetectorParams& params, int cellSize);

  // Searches along the outward normals of every field-coloured contour in `contours` for
  // field -> line -> field transitions; appends nothing, `out` is cleared first.
  void detect(const camera::FrameView& frame, const ContourSet& contours, LinePoints& out);
  // Pixels the last detect() read along the normals.
  int pixelsRead() const { return pixelsRead_; }

 private:
  // Scans from `origin` along unit `normal`; on success the line point's image position.
  bool scan(const camera::FrameView& frame, float originU, float originV, float normalU,
            float normalV, float& lineU, float& lineV);
  float risingEdge(int field, int runStart, int runEnd) const;
  float fallingEdge(int runStart, int runEnd, int field) const;

  const camera::ColourTable& table_;
  const FloorLookup& floor_;
  LineDetectorParams params_;
  int cellSize_;
  // Per contour scratch, reused.
  std::vector<float> smoothU_, smoothV_, tmpU_, tmpV_;
  struct Hit {
    bool found;
    LinePoint point;
  };
  std::vector<Hit> hits_;
  // Pixels along the current normal: position along it (px) and brightness.
  struct Sample {
    float t;
    std::uint8_t luma;
  };
  std::vector<Sample> samples_;
  int pixelsRead_ = 0;
};

struct BallParams {
  camera::ColourClass colour = camera::ColourClass::kOrange;
  // Height of the ball's centre above the floor, m.
  double centreHeight = 0.11;
  // Fewer orange pixels than this is no ball.
  int minPixels = 2;
};

struct BallDetection {
  bool visible = false;
  // Where the ball's centre is seen in the image, px.
  double u = 0, v = 0;
  // Floor point under the ball's centre, robot frame, m.
  double x = 0, y = 0;
  double sigmaRadial = 0, sigmaTangential = 0;
  int pixels = 0;
  int cells = 0;
  double confidence = 0;
};

class BallDetector {
 public:
  BallDetector(const camera::ColourTable& table, const camera::MirrorModel& mirror,
               const BallParams& params);
  // The largest orange region among `contours` (outer contours of the ball colour).
  BallDetection detect(const camera::FrameView& frame, const ContourSet& contours) const;

 private:
  const camera::ColourTable& table_;
  const camera::MirrorModel& mirror_;
  BallParams params_;
};

struct ObstacleParams {
  camera::ColourClass colour = camera::ColourClass::kBlack;
  // Regions smaller than this are ignored, cells.
  int minCells = 4;
};

struct Obstacle {
  // Bearing of the centre of the obstacle's angular extent, robot frame, rad.
  double bearing = 0;
  // Distance to the nearest point on the floor, m.
  double distance = 0;
  double angularWidth = 0;
  // Width across the viewing ray at `distance`, m.
  double width = 0;
  // Nearest floor point, robot frame, m.
  double x = 0, y = 0;
};

class ObstacleDetector {
 public:
  ObstacleDetector(const camera::MirrorModel& mirror, const ObstacleParams& params);
  // One obstacle per outer contour of the obstacle colour.
  void detect(const ContourSet& contours, std::vector<Obstacle>& out) const;

 private:
  const camera::MirrorModel& mirror_;
  ObstacleParams params_;
};

}  // namespace fieldline::region_tracking
