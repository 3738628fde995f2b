// The ball detector's edge insets (BallDetector::edgeInsets): how far inside a ball's silhouette
// its outermost ball-coloured pixel centres lie, by the ball's distance and the image angle of its
// radial direction, in YUYV frames or not, from spheres projected through the mirror model (no
// frames, no renderer). A cell of the table (one distance knot in one angle bin) is sampled the
// first time a lookup needs it, and the table of a mirror and ball height is shared by every
// detector of the process (edgeInsetTableFor): built whole in every detector's constructor it cost
// 79-83 ms of thread CPU at 320x240 and more with the image's area (docs/region_tracking.md).
#pragma once

#include <array>
#include <atomic>
#include <memory>
#include <mutex>

#include "common/camera/mirror_model.hpp"

namespace fieldline::region_tracking {

// Insets at the near edge (toward the mirror centre) and the far edge, px.
struct EdgeInsets {
  double near_px = 0.5, far_px = 0.5;
};

class EdgeInsetTable {
 public:
  // Distance knots kStepM apart, spheres sampled per knot (at kSamples bearings all around and
  // distances spread over the knot's step: sub-pixel shifts), bins of the radial direction's
  // angle to the image rows folded into [0, pi/2] (a YUYV pair lies along a row).
  static constexpr double kStepM = 0.2;
  static constexpr int kSamples = 128;
  static constexpr int kAngleBins = 4;

  // Knots from the nearest ball the mirror shows (centre `centreHeight` up) to one whose near
  // edge is beyond the useful radius (at most 25 m). Samples nothing yet; keeps a copy of the
  // mirror.
  EdgeInsetTable(const camera::MirrorModel& mirror, double centreHeight);
  EdgeInsetTable(const EdgeInsetTable&) = delete;
  EdgeInsetTable& operator=(const EdgeInsetTable&) = delete;

  // Bilinear between the knots and the angle bins' centres around a ball whose centre is
  // `horizontal` m from the mirror axis at `bearing` (axis frame); half a pixel for non-finite
  // input. Samples the cells it needs that were not sampled yet (thread-safe).
  EdgeInsets at(double horizontal, double bearing, bool yuyv) const;
  // One cell: the mean of its spheres' insets, each edge on its own; a cell without a sphere
  // that shows that edge (nearer than the nearest ball, far edges beyond the distance function)
  // takes the nearest nearer knot's mean with one, else the nearest farther one's, else half a
  // pixel.
  EdgeInsets cell(int bin, int knot, bool yuyv) const;

  int knots() const { return knots_; }
  double firstKnotM() const { return first_m_; }
  // Cells sampled so far (of kAngleBins * knots()).
  int cellsSampled() const;

  // Sphere `sample` of a knot: its bearing (axis frame), its distance from the knot in knots
  // (in [-0.5, 0.5)) and its angle bin.
  static double sampleBearing(int sample);
  static double sampleOffset(int sample);
  int sampleBin(int sample) const { return sample_bins_[sample]; }
  // One sphere at `horizontal`, `bearing` (axis frame): its outermost pixel centres' insets
  // from the silhouette, with pixels alone and with YUYV pairs; false where the near edge is not
  // imaged. `far` is NaN where the far edge is beyond the distance function.
  bool sampleInsets(double horizontal, double bearing, EdgeInsets& plain, EdgeInsets& pairs) const;

 private:
  struct Sum {
    double near = 0, far = 0;
    int near_n = 0, far_n = 0;
  };
  struct Cell {
    std::atomic<bool> resolved{false};  // `value` is final
    bool sampled = false;               // `sums` holds the cell's spheres
    std::array<Sum, 2> sums;            // [yuyv]
    std::array<EdgeInsets, 2> value;    // [yuyv]
  };
  // The image radii of a sphere's near and far silhouette edges (far NaN where it is not
  // imaged: beyond the distance function or above the horizon).
  struct EdgeRadii {
    double near, far;
  };
  EdgeRadii edgeRadii(double horizontal, double bearing) const;
  // False where no sphere of the cell can show a far edge (known without scanning pixels).
  bool mayShowFarEdge(int bin, int knot) const;
  const Cell& resolved(int bin, int knot) const;
  // With mutex_ held.
  const Cell& sampled(int bin, int knot) const;
  void resolve(int bin, int knot) const;

  const camera::MirrorModel mirror_;
  const double centre_height_;
  double first_m_ = 0;
  int knots_ = 0;
  std::array<int, kSamples> sample_bins_{};
  mutable std::mutex mutex_;
  std::unique_ptr<Cell[]> cells_;  // [bin * knots_ + knot]
};

// The table of this mirror and ball height: one per process for equal parameters (the last few
// kept), so that detectors built again (a new frame size and back, tests, tools) sample each
// cell once. Thread-safe.
std::shared_ptr<const EdgeInsetTable> edgeInsetTableFor(const camera::MirrorModel& mirror,
                                                        double centreHeight);

}  // namespace fieldline::region_tracking
