// Field lines along the normals of the field-coloured region boundaries (seed 3.3): walks from
// the boundary outward through field, line, field, with sub-pixel edges, mapped to the robot
// frame through the floor lookup. The walks and tables are built once (line_detector_tables.cpp),
// the samples along each contour placed per frame (line_sampling.cpp), the scans and their
// grouping into sequences run here (line_detector.cpp).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/perception/line_points.hpp"
#include "services/region_tracking/class_lookup.hpp"
#include "services/region_tracking/contours.hpp"
#include "services/region_tracking/floor_lookup.hpp"

namespace fieldline::region_tracking {

using perception::LinePoint;
using perception::LinePoints;

struct LineDetectorParams {
  camera::ColourClass field_colour = camera::ColourClass::kGreen;
  camera::ColourClass line_colour = camera::ColourClass::kWhite;
  // Width of the field lines, m: bounds the length of a white run along a normal.
  double line_width = 0.125;
  // A white run may be up to this many times the line's expected width in pixels (+ 2 px).
  double width_tolerance = 2.5;
  // Pixels of neither class allowed between green and white (blurred edges).
  int max_transition_pixels = 2;
  // Sensor noise: up to this many consecutive pixels of another class inside a line's run are
  // holes in it (0 = a clean run only).
  int max_gap_pixels = 1;
  // Field pixels after the run that confirm the line's end (a single green pixel may be noise
  // inside the line); fewer suffice where the walk ends or another line follows. 1 = the first
  // field pixel ends it.
  int field_confirm_pixels = 1;
  // A line may also end at the robot's own reflection (dark pixels without a floor point), e.g.
  // the centre circle under the robot.
  bool end_at_self = true;
  // Blurred thin lines: optics blur a far line into a ridge of brightness that is neither field
  // nor line colour (its peak mixes paint with carpet). A run of unclassified pixels between two
  // field pixels, no longer than a line's longest run plus both transitions, is a line when its
  // brightest pixel is at least `ridge_contrast` times as bright as the brighter of the two field
  // pixels and at least `ridge_min_levels` above it (0 = off: only runs of the line colour).
  double ridge_contrast = 1.3;
  int ridge_min_levels = 16;
  // The detector runs at every n-th contour corner (when sample_spacing_m is 0), then the
  // refinement below when it is on (with it, 4: about the scans of 2 without it).
  int sample_spacing = 4;
  // Sampling by distance on the field instead (0 = off): the detector runs every this many
  // metres of floor along the smoothed contour, at fractional positions between its corners
  // where a corner step spans more floor than that (far from the robot) and every few corners
  // near it. Far lines get the points that their features need; near lines give fewer.
  double sample_spacing_m = 0.0;
  // With sample_spacing_m: samples at least this many pixels apart along the smoothed contour
  // (far away a pixel spans decimetres of floor, and two scans within a pixel read the same
  // pixels).
  double sample_min_px = 2.0;
  // With sample_spacing_m: where the contour turns (a line's corner or junction, where the
  // features are), denser. Within `turn_reach_m` of floor along the contour from a point where
  // the contour's floor direction turns by more than `turn_angle` (rad) between the
  // `turn_span` corner steps before and after it, the spacing is `turn_spacing_m` (0 = no
  // denser sampling).
  double turn_spacing_m = 0.0;
  double turn_reach_m = 0.7;
  // Only turns within this floor distance of the robot count, m (features further away are not
  // looked for; far turns cost points for nothing).
  double turn_range_m = 4.5;
  double turn_angle = 0.5;
  int turn_span = 3;
  // Refinement where the features are (sampling by index only; 0 = off, 4.5 with
  // sample_spacing 4 is the measured setting, feature_recognition.md): after the scans every
  // `sample_spacing` corners, a line point between `refine_min_range_m` and `refine_range_m`
  // of the robot (floor distance) where its line ends (a neighbouring sample found no line) or
  // turns (the floor directions to the line points of both neighbouring samples differ by more
  // than `refine_turn` rad) gets `refine_samples` more scans in each of the `refine_reach`
  // sample intervals on both sides of it, evenly between the samples. The scans follow the
  // lines that need them (a penalty area's corners 2-4 m away) instead of every contour's turns.
  double refine_range_m = 4.5;
  double refine_min_range_m = 0.0;
  int refine_samples = 4;
  // With refine_spacing_m > 0: an interval gets only as many of its refine_samples scans as
  // put them this far apart on the floor (fewer near the robot, where a pixel is less floor).
  double refine_spacing_m = 0.1;
  // 1 since 2026-12-03 (2 before: 17 % fewer pixels read now, corner rate 0.83 against 0.86;
  // see vision_default.yaml).
  int refine_reach = 1;
  double refine_turn = 0.5;
  // Whether a line point without a line point at either neighbouring sample (a lone point:
  // clutter more often than a line) is refined too.
  bool refine_isolated = false;
  // Passes of 0.25/0.5/0.25 smoothing of the contour before tangents are taken.
  int smoothing_passes = 3;
  // Tangent from the points this many corners before and after.
  int tangent_half_span = 2;
  // Contours with fewer corners are skipped (noise regions).
  int min_contour_points = 16;
  // Consecutive samples without a detection that still continue a sequence.
  int max_gap_samples = 1;
};

class LineDetector {
 public:
  LineDetector(const camera::ColourTable& table, const FloorLookup& floor,
               const LineDetectorParams& params, int cell_size);
  // With the classes of `lookup` (which must outlive this), shared with the cell classifier.
  LineDetector(const ClassLookup& lookup, const FloorLookup& floor,
               const LineDetectorParams& params, int cell_size);

  // Searches along the outward normals of every field-coloured contour in `contours` for
  // field -> line -> field transitions; appends nothing, `out` is cleared first. Throws
  // std::invalid_argument for a frame of another size than the floor lookup's.
  void detect(const camera::FrameView& frame, const ContourSet& contours, LinePoints& out);
  // Pixels the last detect() read along the normals.
  int pixelsRead() const { return pixels_read_; }
  // Scans (searches along a normal) the last detect() ran: with pixelsRead(), its cost.
  int scans() const { return scans_; }
  // Floor length (m) of the image step (du, dv) px taken at the image point (u, v): the floor
  // lookup's Jacobian at the nearest cell corner applied to the step; 0 where that corner has
  // no usable floor. Used by the sampling by distance (sample_spacing_m).
  float floorLength(float u, float v, float du, float dv) const {
    float dx, dy;
    return floorStep(u, v, du, dv, dx, dy) ? std::sqrt(dx * dx + dy * dy) : 0.0f;
  }
  // The floor step (dx, dy) m itself; false (and 0) where no floor.
  bool floorStep(float u, float v, float du, float dv, float& dx, float& dy) const;

 private:
  // One pixel of a walk along a normal: offset from the pixel nearest the walk's origin.
  struct Step {
    std::int8_t du, dv;
  };
  // Normals are quantised to this many directions for the precomputed walks (at most 0.9 deg
  // off); positions along the normal are still measured along the exact normal.
  static constexpr int kDirections = 256;
  static int directionOf(float normalU, float normalV);
  // Steps are 8-bit offsets, so a walk has at most this many pixels.
  static constexpr int kMaxWalk = 256;

  // Scans from `origin` along `normal` (any length); on success the line point's image position.
  template <camera::PixelFormat kFormat>
  bool scan(const camera::FrameView& frame, float originU, float originV, float normalU,
            float normalV, float& lineU, float& lineV);
  // The brightest sample strictly between the field samples `fieldBefore` and `fieldAfter` when
  // it is bright enough for a ridge (ridge_contrast, ridge_min_levels), else -1.
  int ridgePeak(const std::uint8_t* luma, int fieldBefore, int fieldAfter) const;
  // Where the brightness crosses halfway between the field sample `field` and `peak`, the
  // brightest sample of the line run [runStart, runEnd], along the normal; `luma` holds the
  // walk's brightness.
  float risingEdge(const std::uint8_t* luma, int field, int runStart, std::uint8_t peak) const;
  float fallingEdge(const std::uint8_t* luma, int runEnd, std::uint8_t peak, int field) const;
  // Position along the current normal of step `index` of the current walk (pixel centre
  // projected on the exact normal).
  float along(int index) const {
    const Step step = walk_[index];
    return (step.du - walk_fraction_u_) * walk_normal_u_ +
           (step.dv - walk_fraction_v_) * walk_normal_v_;
  }
  // Smoothed contour point `i` (0 <= i < contour size) into `u`, `v` from padded_u_, padded_v_
  // with any kernel (smoothContour sums the default one in integers).
  void smoothedPoint(int i, float& u, float& v) const;

  LineDetector(std::shared_ptr<const ClassLookup> lookup, const FloorLookup& floor,
               const LineDetectorParams& params, int cell_size);

  std::shared_ptr<const ClassLookup> lookup_;  // owned when made from a table
  const FloorLookup& floor_;
  LineDetectorParams params_;
  int cell_size_;
  // Small tables, so that a scan's look-ups stay in the L1 cache: whether each pixel has a
  // usable floor point (one bit per pixel), and the longest white run accepted in each block of
  // 8x8 pixels (the largest over its usable pixels, from their finest m/px).
  static constexpr int kRunBlockShift = 3;
  bool usable(int u, int v) const {
    return (usable_[static_cast<std::size_t>(v) * usable_words_per_row_ + (u >> 6)] >> (u & 63)) &
           1;
  }
  int maxRunAt(int u, int v) const {
    return max_run_by_block_[static_cast<std::size_t>(v >> kRunBlockShift) * run_blocks_per_row_ +
                             (u >> kRunBlockShift)];
  }
  int usable_words_per_row_;
  std::vector<std::uint64_t> usable_;
  int run_blocks_per_row_;
  std::vector<std::uint8_t> max_run_by_block_;
  // Walks: for every direction the distinct pixels met stepping 1 px along the normal from
  // t = first_step_ to last_step_, and how many of them lie at t or before.
  int first_step_;
  int last_step_;
  int walk_capacity_;
  std::vector<Step> walks_;
  std::vector<std::uint8_t> walk_count_up_to_;
  // Index into a direction's walk_count_up_to_ of the step that probes for the view's edge (one
  // past the cell), and of the last step less the longest run at the origin.
  int probe_step_;
  int stop_step_base_;
  // Per direction the step that probes for the view's edge (walk step probe_step_), so that a
  // scan outside the view is refused without reading its walk.
  std::array<Step, kDirections> probes_{};
  // Binomial kernel equal to smoothing_passes passes of 0.25/0.5/0.25.
  std::vector<float> smoothing_kernel_;
  // Scratch, reused: a contour's corners with the kernel's reach wrapped around on both sides
  // (kernels other than the default's), and the smoothed points of every contour of the frame.
  int pad_ = 0;
  std::vector<float> padded_u_, padded_v_;
  std::vector<float> smooth_u_, smooth_v_;
  struct Hit {
    bool found;
    LinePoint point;
  };
  // Hits kept from frame to frame (the storage only grows). Appending misses stores each in
  // place: std::vector's resize with a value copied the value through the stack for every
  // element, a byte stored and read back as 16 bytes, which stalled store forwarding once per
  // hit (6 % of the detector's time).
  class HitList {
   public:
    void clear() { size_ = 0; }
    int size() const { return size_; }
    Hit* data() { return hits_.data(); }
    Hit& operator[](int i) { return hits_[static_cast<std::size_t>(i)]; }
    // Appends `count` misses; the first of them.
    Hit* appendMisses(int count) {
      makeRoom(count);
      Hit* const first = hits_.data() + size_;
      for (int i = 0; i < count; ++i) {
        first[i].found = false;
        first[i].point = LinePoint{};
      }
      size_ += count;
      return first;
    }
    void push(const Hit& hit) {
      makeRoom(1);
      hits_[static_cast<std::size_t>(size_++)] = hit;
    }

   private:
    void makeRoom(int count) {
      const std::size_t needed = static_cast<std::size_t>(size_) + static_cast<std::size_t>(count);
      if (needed > hits_.size()) hits_.resize(std::max(needed, 2 * hits_.size()));
    }
    std::vector<Hit> hits_;
    int size_ = 0;
  };
  // Per frame, every scanned contour's smoothed points (smooth_u_, smooth_v_ from
  // smooth_begin) and pass-1 hits (hits_ from hits_begin); with the refinement the hits of both
  // passes in contour order (merged_hits_ from merged_begin, -1: not refined).
  struct ContourWork {
    int smooth_begin = 0, smoothed = 0, sample_step = 1, tangent_reach = 1;
    int hits_begin = 0, samples = 0;
    int merged_begin = -1, merged_count = 0;
  };
  std::vector<ContourWork> work_;
  HitList hits_;
  // Refinement (refine_range_m): per pass-1 interval of a contour whether it is refined, the
  // hits of both passes, and the ranges of merged_hits_ its scans filled (first, count).
  std::vector<std::uint8_t> refine_interval_;
  HitList merged_hits_;
  std::vector<std::pair<int, int>> refined_;
  // The steps of detect() (line_detector.cpp): pass 1 smooths every field contour and scans at
  // its samples; pass 2 (refine_range_m) scans again around line points where a line ends or
  // turns; then the hits of each contour become sequences of line points.
  void scanContours(const camera::FrameView& frame, const ContourSet& contours);
  void refineContours(const camera::FrameView& frame);
  // Pass 2 for one contour: marks its intervals to refine (refine_interval_), false if none.
  bool markRefinedIntervals(const ContourWork& w);
  // Pass 2 for one contour: its hits and the marked intervals' scans into merged_hits_.
  void refineContour(const camera::FrameView& frame, ContourWork& w, float perMetre);
  void groupSequences(LinePoints& out);
  // Tangent (difference of the smoothed corners tangent_reach before and after) at `centre`.
  void tangentAt(const ContourWork& w, int centre, float& tu, float& tv) const;
  // One scan from (originU, originV) across the tangent (tu, tv); the hit's image position.
  void scanAcross(const camera::FrameView& frame, float originU, float originV, float tu, float tv,
                  Hit& hit);
  // A scan at a fractional position among the smoothed corners (index + fraction of the step
  // after it): the curve and its tangent interpolated linearly.
  void scanAt(const camera::FrameView& frame, const ContourWork& w, float position, Hit& hit);
  // The floor points of hits found by scans, looked up once the table entries prefetched at
  // each hit have had the other contours' scans to arrive.
  void toFloor(Hit* hits, std::size_t count) const;
  // Construction steps (line_detector_tables.cpp): the usable-pixel bits and run limits
  // (returns the longest run anywhere), the precomputed walks, the smoothing kernel, the floor's
  // Jacobians at the cell corners.
  int buildRunTables();
  void buildWalks();
  void buildSmoothingKernel();
  void buildJacobians();
  // Every `stride`-th smoothed corner of the closed contour `corners` (n corners) into su, sv.
  void smoothContour(const ContourPoint* corners, int n, int stride, float* su, float* sv);
  // Sampling by distance: samples along the closed smoothed contour su, sv (index + fraction of
  // the corner step after it).
  void sampleByDistance(const float* su, const float* sv, int n, std::vector<float>& positions);
  // Its steps (line_sampling.cpp): the floor step of every corner step (step_x_, step_y_,
  // step_length_); which steps lie near a turn (near_turn_; false when turns are off).
  void measureSteps(const float* su, const float* sv, int n);
  bool markNearTurns(const float* su, const float* sv, int n);
  std::vector<float> sample_positions_;
  // Per corner step of the current contour: floor step (m) and whether it is near a turn.
  std::vector<float> step_x_, step_y_, step_length_;
  std::vector<std::uint8_t> near_turn_, turn_;
  // Jacobian of the floor point by the image point (m/px: dx/du, dx/dv, dy/du, dy/dv) at every
  // cell corner (pixel (i * cell_size - 0.5, j * cell_size - 0.5)); NaN where no floor.
  struct Jacobian {
    float xu, xv, yu, yv;
    // Squared floor distance of the corner from the robot, m^2.
    float range2;
  };
  // The table entry of the cell corner nearest to pixel (u, v); nullptr outside the image.
  const Jacobian* jacobianNear(float u, float v) const;
  int jacobian_columns_ = 0, jacobian_rows_ = 0;
  std::vector<Jacobian> jacobians_;
  // The walk of the current scan, for along().
  const Step* walk_ = nullptr;
  float walk_fraction_u_ = 0, walk_fraction_v_ = 0, walk_normal_u_ = 0, walk_normal_v_ = 0;
  int pixels_read_ = 0;
  int scans_ = 0;
};

}  // namespace fieldline::region_tracking
