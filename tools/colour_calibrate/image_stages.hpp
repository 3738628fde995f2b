// The stages of calibrateFromImages (image_calibration.hpp) and what they share, for the files
// that implement them: image_calibration.cpp (the floor, the lines, the table) and
// image_objects.cpp (the ball and the robots, from blobs that are neither floor nor line).
// Internal to the colour calibration library.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "tools/calibration_common/floor_colour.hpp"
#include "tools/calibration_common/ridges.hpp"
#include "tools/colour_calibrate/image_calibration.hpp"

namespace fieldline::calibration::imagefit {

using camera::Vec2;
using camera::Yuv;

double chromaDistance(const Yuv& c, double u, double v);

// Per pixel of the image: where it looks on the floor.
struct PixelGeometry {
  std::vector<double> distance;  // robot-frame floor distance, NaN outside the useful zone
  std::vector<Vec2> robot;       // robot-frame floor point
  std::vector<double> mpp_min;   // the finer of radial and tangential metres per pixel
};

PixelGeometry geometryOf(const camera::MirrorModel& mirror);

// A class as a cone through the white point: chroma (c - w) / Y near `ratio`, within `radius`
// levels at luma `ref_y` (growing with luma above it, noise below), luma in [y_lo, y_hi].
struct Cone {
  double ru = 0.0, rv = 0.0;
  double radius = 0.0;
  double ref_y = 1.0;
  double y_lo = 0.0, y_hi = 255.0;
  bool contains(double y, double u, double v, double wu, double wv) const {
    if (y < y_lo || y > y_hi) return false;
    const double pu = wu + ru * y, pv = wv + rv * y;
    return std::hypot(u - pu, v - pv) <= radius * std::max(1.0, y / ref_y);
  }
};

// The cone of samples `s`: the median chroma ratio of their brighter half, the radius their 99th
// percentile from it (at least min_radius), luma from their low_pct to high_pct percentiles
// widened by the light range.
Cone coneOf(const std::vector<Yuv>& s, double wu, double wv, const std::array<double, 2>& light,
            double min_radius, double low_pct, double high_pct);

struct Blob {
  std::vector<int> pixels;
  Vec2 centroid = Vec2::Zero();
  double mean_y = 0.0;
  double chroma = 0.0;  // mean distance from the white point
  int frame = 0;
  double aspect = 1.0;  // of its bounding box, long side over short side
};

// One calibration from frames in progress: the stages in the order calibrateFromImages runs
// them, each reading and writing the shared state below.
struct FromImages {
  FromImages(const camera::MirrorModel& mirror, const field::FieldModel& field,
             const std::vector<camera::FrameView>& frames,
             const std::vector<std::optional<geometry::Pose2>>& poses,
             const ImageFitParams& params);

  // The floor: the dominant colour in the annulus; Refusal when there is none.
  void findFloor();
  // Lines: narrow bright ridges with floor on both sides; their samples, and around them the
  // pixels that are no floor.
  void findLines();
  void addLineRidge(std::size_t f, const Ridge& r);
  // Floor samples: floor chroma, not on a ridge, in the annulus and beyond to the lines' range.
  void sampleFloor();
  // The lines' luma and the white point; Refusal when they are not brighter than the floor.
  void measureLines();
  // The floor's cone: the carpet's colour under every light of the fit (its chroma moves with
  // the light under a colour cast, away from the white point as it brightens).
  void fitFloorCone();
  // The ball and the robots: what is neither, inside the field (needs the poses).
  void findBallAndRobots();
  std::vector<std::uint8_t> otherMask(std::size_t f) const;
  // The blobs of frame f that look like a ball: made of pixels that are neither floor, line,
  // nor of the floor's cone (otherwise the carpet's brighter or noisier pixels, beyond the
  // floor's chroma reach, join a ball's blob and make it too large, or form blobs of a ball's
  // size that pass for one).
  std::vector<Blob> ballBlobs(std::size_t f) const;
  std::vector<Blob> blobsOf(std::size_t f, const std::vector<std::uint8_t>& other) const;
  bool looksLikeABall(const Blob& b) const;
  bool isRobot(const Blob& b) const {
    return b.mean_y < 0.75 * out.floor.median[0] && b.pixels.size() >= 30;
  }
  void chooseBall(const std::vector<Blob>& balls);
  // The lookup table from the classes' cones.
  void buildTable();
  // Leaves the ball samples `floorOrLine` (y, u, v) calls the carpet's or the lines' out of
  // out.samples.ball, counts them, and drops the ball when fewer than 5 are left.
  void keepBallSamples(const std::function<bool(double, double, double)>& floorOrLine);

  bool hasPose(std::size_t f) const { return !poses.empty() && poses[f].has_value(); }
  bool isFloor(const Yuv& c) const { return floor_colour.contains(c); }

  const camera::MirrorModel& mirror;
  const field::FieldModel& field;
  const std::vector<camera::FrameView>& frames;
  const std::vector<std::optional<geometry::Pose2>>& poses;
  const ImageFitParams& params;
  const int w, h;
  const std::size_t n;
  const PixelGeometry geo;
  std::vector<std::vector<Yuv>> planes;
  ImageCalibration out;
  FloorColour floor_colour;
  std::vector<std::vector<std::uint8_t>> ridge_mask;
  std::vector<double> floor_luma_near;  // the flank of every line ridge
  std::vector<double> fy, ly;           // the floor's and the lines' luma samples
  double wu = 0.0, wv = 0.0;            // the white point
  double line_chroma = 0.0;             // p95 of the line samples' distance from it, + 2
  Cone floor_cone;
  bool floor_cone_fitted = false;  // fitFloorCone ran (ballBlobs and buildTable read the cone)
  // Throws std::logic_error naming `stage` when fitFloorCone has not run.
  void requireFloorCone(const char* stage) const;
};

}  // namespace fieldline::calibration::imagefit
