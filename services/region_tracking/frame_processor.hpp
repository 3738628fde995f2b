// The whole vision step of one frame: track the colour regions, extract their boundaries, and
// run the detectors on them (field lines every n-th frame, ball and obstacles every frame).
// The region_tracking node wraps this; the benchmark and the PNG tool use it directly.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/config/config.hpp"
#include "services/region_tracking/detectors.hpp"
#include "services/region_tracking/frame_classifier.hpp"
#include "services/region_tracking/region_tracker.hpp"

namespace fieldline::region_tracking {

struct VisionParams {
  TrackerConfig tracker;
  BlockClassifierParams blocks;
  LineDetectorParams lines;
  BallParams ball;
  ObstacleParams obstacles;
};

// Green searched for when lost (every region of at least 4 cells) and seeded at the edge of the
// view; goal colours, ball and obstacles seeded from green's boundary every frame; 4x4 cells;
// re-initialisation every 300 frames (services/region_tracking/vision_default.yaml).
VisionParams defaultVisionParams();

// Reads a vision preset: sections tracker (see loadTrackerConfig, class names as in
// camera::colourName), blocks {claims: [{class, min_fraction}]}, lines {line_width,
// width_tolerance, max_transition_pixels, sample_spacing, smoothing_passes, tangent_half_span,
// min_contour_points, max_gap_samples, optional max_gap_pixels, field_confirm_pixels,
// end_at_self, ridge_contrast, ridge_min_levels}, ball {centre_height, min_pixels, optional
// size_tolerance, size_slack_px, min_fill, min_carpet_share}, obstacles {min_cells}. Every key is
// required in its section except those documented optional in loadTrackerConfig.
VisionParams loadVisionParams(const config::Node& node);

struct VisionResult {
  TrackingStats tracking;
  bool lines_detected = false;
  LinePoints lines;
  BallDetection ball;
  std::vector<Obstacle> obstacles;
};

class FrameProcessor {
 public:
  // `mirror` and `table` must outlive the processor. Frames must have the mirror model's size.
  // The tracker and the line detector classify with a copy of the table's classes, taken anew
  // at the next frame when the table changed (ColourTable::generation), or at once by
  // coloursChanged().
  FrameProcessor(const camera::MirrorModel& mirror, const camera::ColourTable& table,
                 const VisionParams& params);
  // The classifier and the line detector point into this object (its lookup, its floor).
  FrameProcessor(const FrameProcessor&) = delete;
  FrameProcessor& operator=(const FrameProcessor&) = delete;

  // The colour table changed (the colour adaptation rebuilt it): the classes are taken anew.
  void coloursChanged() {
    lookup_.rebuild(table_);
    lookup_generation_ = table_.generation();
  }
  // Throws std::invalid_argument for an invalid view or a frame of another size.
  void process(const camera::FrameView& frame, bool detectLines, VisionResult& out);
  // Where a ball can be for the following frames (fusion's pose on the field); nullopt: the
  // ball is judged by the image alone.
  void setBallRegion(const std::optional<BallRegion>& region) { ball_region_ = region; }

  const RegionTracker& tracker() const { return tracker_; }
  RegionTracker& tracker() { return tracker_; }
  const CellGrid& grid() const { return grid_; }
  const ClassLookup& classLookup() const { return lookup_; }
  const std::vector<std::uint8_t>& dontTouch() const { return dont_touch_; }
  const FloorLookup& floor() const { return floor_; }
  FrameCellClassifier& classifier() { return classifier_; }
  LineDetector& lineDetector() { return lines_; }
  const BallDetector& ballDetector() const { return ball_; }
  const ObstacleDetector& obstacleDetector() const { return obstacles_; }

 private:
  const camera::MirrorModel& mirror_;
  const camera::ColourTable& table_;
  // The table's classes for the classifier and the line detector (class_lookup.hpp).
  ClassLookup lookup_;
  std::uint64_t lookup_generation_ = 0;  // the table's generation lookup_ holds
  CellGrid grid_;
  std::vector<std::uint8_t> dont_touch_;
  FloorLookup floor_;
  FrameCellClassifier classifier_;
  RegionTracker tracker_;
  LineDetector lines_;
  BallDetector ball_;
  ObstacleDetector obstacles_;
  std::optional<BallRegion> ball_region_;
};

}  // namespace fieldline::region_tracking
