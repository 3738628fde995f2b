// Is the vision seeing? (issue 12, part 5.) A colour table that does not fit the light, a
// covered lens or a washed-out carpet leave the tracker running without error but blind. This
// watches every frame and names the condition, so the process's status says WARN with the
// reason instead of "ok":
//
//   - too little green: a fixed sparse grid of floor pixels inside the useful radius is
//     classified through the colour table; the share that is green, averaged over the window;
//   - the ball class everywhere: the share of those pixels that is orange, averaged;
//   - no line points: the last `max_line_frames_without_points` line-detection frames found none;
//   - re-seeding every frame: green had to be searched for in the whole frame (the tracker lost
//     all its regions) in more than `max_search_fraction` of the window's frames.
//
// With a field model and fusion's pose at the frame's time (issue 30: a table that gives plenty
// of wrong points passes every check above), on the line-detection frames:
//   - line points on no line: the share of the points within `field_range_m` that lie further
//     than `off_line_m` (plus the pose's sigma) from every line of the model: an estimate of
//     1 - precision;
//   - line points off the field: the share beyond the touch and goal lines' outer edges;
//   - floor colour beyond the field: the share of the sampled floor pixels that see the hall
//     floor beyond the carpet and are classified as field colour (a table whose green spans
//     every grey);
//   - fewer points than the field predicts: the share of the model's line length in view
//     (within range, where the mirror sees the floor) that has a line point within
//     `coverage_distance_m`: a table that finds a fraction of the lines.
// Each over the last `field_window_frames` line frames that had a pose; without a pose (fusion
// not tracking, or its pose too uncertain) the field checks say nothing.
//
// The grid sample is independent of the tracker's state (it sees the frame, not what the tracker
// kept), costs about a thousand table lookups per frame, and allocates nothing per frame.
// Plain library: no LCM, no clock.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/config/config.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "services/region_tracking/class_lookup.hpp"
#include "services/region_tracking/frame_processor.hpp"

namespace fieldline::region_tracking {

struct VisionHealthParams {
  // Frames the shares and the search rate are averaged over.
  int window_frames = 30;
  // Below this share of green among the sampled floor pixels: "too little green". A robot in a
  // corner of the msl field still sees about 35 % carpet within its useful radius.
  double min_green_fraction = 0.15;
  // Above this share of orange: "ball class everywhere" (a ball at 0.3 m covers < 1 %).
  double max_orange_fraction = 0.05;
  // Consecutive line-detection frames without a single line point.
  int max_line_frames_without_points = 10;
  // Share of the window's frames with an initial search of the whole frame.
  double max_search_fraction = 0.5;
  // Spacing of the sample grid, px.
  int sample_stride = 8;

  // Field checks (with a field model and a pose): line frames averaged over, the range of the
  // points and floor samples looked at (m), and the limits.
  int field_window_frames = 10;
  double field_range_m = 4.0;
  // A point further than this plus the pose's sigma from every line is on no line, m.
  double off_line_m = 0.25;
  // Above this share of the points on no line, or off the field: WARN.
  double max_off_line_share = 0.2;
  double max_off_field_share = 0.1;
  // Above this share of the floor beyond the carpet classified as field colour: WARN.
  double max_green_beyond_share = 0.3;
  // Below this share of the line length in view covered by points: WARN. A model line sample
  // counts as covered with a point within coverage_distance_m.
  double min_line_coverage = 0.3;
  // At most field_range_m / kMaxRangeOverCoverage (below): the coverage grid, one byte per
  // square of this side over the square of twice field_range_m, stays under 170 kB (20 m at
  // 0.01 m would take 16 MB).
  double coverage_distance_m = 0.25;
  // Too few facts to judge: fewer points / floor samples beyond the carpet / metres of line in
  // view over the window than these.
  int min_field_points = 40;
  int min_beyond_samples = 40;
  double min_line_in_view_m = 5.0;
  // A pose whose position sigma is larger is not used, m.
  double max_pose_sigma_m = 0.3;
};

// The largest field_range_m / coverage_distance_m: the coverage grid is (2 (ceil(ratio) + 2) + 1)^2
// bytes, 164 kB at this bound (1.4 kB with the defaults, 4 m / 0.25 m).
inline constexpr double kMaxRangeOverCoverage = 200.0;

// Fusion's pose at a frame's time and how sure it is.
struct FramePose {
  geometry::Pose2 pose;
  // Position standard deviation (the larger axis), m.
  double sigma_m = 0.0;
};

// Reads a `health` section (every key optional, defaults as above; unknown keys are errors, and
// so is a coverage_distance_m below field_range_m / kMaxRangeOverCoverage).
VisionHealthParams loadVisionHealthParams(const config::Node& node);

class VisionHealth {
 public:
  // `mirror`, `table` and `field` (may be null: no field checks) must outlive this. Throws
  // std::invalid_argument for bad parameters (a coverage grid over the bound among them).
  // With `lookup` (the classes of `table`, e.g. the FrameProcessor's, which then stays warm in the
  // cache for both; it must outlive this) YUYV samples are classified there.
  VisionHealth(const camera::MirrorModel& mirror, const camera::ColourTable& table,
               const VisionHealthParams& params, const field::FieldModel* field = nullptr,
               const ClassLookup* lookup = nullptr);

  // One processed frame and what the tracker made of it; `pose`: fusion's pose at the frame's
  // time, when known (the field checks use it on line frames).
  void update(const camera::FrameView& frame, const VisionResult& result,
              const std::optional<FramePose>& pose = std::nullopt);

  // Empty while the vision looks healthy, else the conditions ("too little green: 2 % of the
  // floor (< 15 %); no line points in 10 line frames").
  const std::string& reason() const { return reason_; }
  bool healthy() const { return reason_.empty(); }
  // Window averages, for metrics.
  double greenFraction() const;
  double orangeFraction() const;
  double searchFraction() const;
  int lineFramesWithoutPoints() const { return line_frames_without_points_; }
  int samplePixels() const { return static_cast<int>(samples_.size()); }
  // The coverage grid's size (bounded by kMaxRangeOverCoverage).
  std::size_t coverageGridBytes() const { return bins_.size(); }
  // Field checks over the window (negative: not enough facts to judge).
  double offLineShare() const;
  double offFieldShare() const;
  double greenBeyondShare() const;
  double lineCoverage() const;
  // Line frames in the window that had a pose.
  int posedLineFrames() const;

 private:
  // A sample pixel, 4 bytes: every frame reads all of them, usually from memory the other
  // processes have taken the cache from (issue 32: cache lines, not instructions, are what a frame
  // costs in the team).
  struct SamplePixel {
    std::uint16_t u, v;
  };
  // A sample that sees a floor point within field_range_m: that point (robot frame) and the
  // sample's index, side by side for fieldFacts' pass over them.
  struct InRangeSample {
    float x, y;
    std::uint32_t index;
  };
  struct FrameFacts {
    float green = 0, orange = 0;
    bool searched = false;
  };
  // What one line frame with a pose showed of the field.
  struct FieldFacts {
    bool posed = false;
    int points = 0, off_line = 0, off_field = 0;
    int beyond = 0, green_beyond = 0;
    double in_view_m = 0.0, covered_m = 0.0;
  };
  double mean(float FrameFacts::*field) const;
  // This frame's class of every sample (sample_classes_) and the counts of green, orange and
  // samples inside the frame.
  void classifySamples(const camera::FrameView& frame, int& green, int& orange, int& counted);
  // Non-const: fills the reused buffers below.
  FieldFacts fieldFacts(const VisionResult& result, const FramePose& pose);
  // The model's line in view at `pose` and the part of it with a line point nearby (fieldFacts).
  void lineCoverageFacts(const VisionResult& result, const geometry::Pose2& pose, FieldFacts& f);
  // Whether field_->distance(p) > reach, for a point p within `range` of the position the
  // shortlist below was made for (selectNearbyLines).
  bool fartherThan(const geometry::Vec2& p, double reach) const;
  void selectNearbyLines(const geometry::Vec2& centre, double range, double reach);
  // Fills line_samples_ and line_buckets_ (construction).
  void bucketLineSamples(const std::vector<geometry::Vec2>& samples);
  FieldFacts fieldSum() const;
  // Whether the floor point `robot` (robot frame) is seen in the mirror's useful zone at least
  // `min_radius` px from its centre: mirror_.robotToImage, zone and radiusOf.
  bool usefullyInView(const geometry::Vec2& robot, double min_radius) const;
  // Whether any point of this frame lies in the coverage bin (bx, by) or one beside it.
  bool nearPoint(int bx, int by) const;

  const camera::ColourTable& table_;
  const ClassLookup* lookup_;
  const camera::MirrorModel& mirror_;
  const field::FieldModel* field_;
  VisionHealthParams params_;
  std::vector<SamplePixel> samples_;
  // This frame's class of each sample.
  std::vector<camera::ColourClass> sample_classes_;
  // The samples that see a floor point within field_range_m (fixed in the robot frame), in
  // their order: the only ones the field checks look at.
  std::vector<InRangeSample> in_range_samples_;
  // The model's lines, sampled every line_sample_m (field frame), grouped by the square of
  // line_bucket_m_ they lie in (line_buckets_: [begin, end) into line_samples_ per square, row
  // by row from line_origin_): a frame looks only at the squares near its pose.
  std::vector<geometry::Vec2> line_samples_;
  double line_sample_m_ = 0.1;
  double line_bucket_m_ = 1.0;
  geometry::Vec2 line_origin_ = geometry::Vec2::Zero();
  int line_columns_ = 0, line_rows_ = 0;
  std::vector<std::pair<std::size_t, std::size_t>> line_buckets_;
  // This frame's field lines that can be near its points (fieldFacts).
  std::vector<const field::LineSegment*> near_segments_;
  std::vector<const field::LineArc*> near_arcs_;
  // This frame's points binned on a grid of the coverage distance (robot frame), bins
  // -bin_half_..bin_half_ in x and y: one byte per bin, set where a point lies (the bins set
  // listed, to clear them). Points beyond it are never beside a sample within range.
  int bin_half_ = 0;
  std::vector<std::uint8_t> bins_;
  std::vector<std::size_t> bins_set_;
  std::vector<FieldFacts> field_window_;  // ring buffer of line frames
  std::size_t field_next_ = 0;
  std::size_t field_filled_ = 0;
  // fieldSum() of the window as it is since the last update.
  FieldFacts field_sum_;
  std::vector<FrameFacts> window_;  // ring buffer
  std::size_t next_ = 0;
  std::size_t filled_ = 0;
  int line_frames_without_points_ = 0;
  std::string reason_;
};

}  // namespace fieldline::region_tracking
