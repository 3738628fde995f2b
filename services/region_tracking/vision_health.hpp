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
// The grid sample is independent of the tracker's state (it sees the frame, not what the tracker
// kept), costs about a thousand table lookups per frame, and allocates nothing per frame.
// Plain library: no LCM, no clock.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/camera/colour.hpp"
#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/config/config.hpp"
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
};

// Reads a `health` section (every key optional, defaults as above; unknown keys are errors).
VisionHealthParams loadVisionHealthParams(const config::Node& node);

class VisionHealth {
 public:
  // `mirror` and `table` must outlive this. Throws std::invalid_argument for bad parameters.
  VisionHealth(const camera::MirrorModel& mirror, const camera::ColourTable& table,
               const VisionHealthParams& params);

  // One processed frame and what the tracker made of it.
  void update(const camera::FrameView& frame, const VisionResult& result);

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

 private:
  struct Sample {
    int u, v;
  };
  struct FrameFacts {
    float green = 0, orange = 0;
    bool searched = false;
  };
  double mean(float FrameFacts::*field) const;

  const camera::ColourTable& table_;
  VisionHealthParams params_;
  std::vector<Sample> samples_;
  std::vector<FrameFacts> window_;  // ring buffer
  std::size_t next_ = 0;
  std::size_t filled_ = 0;
  int line_frames_without_points_ = 0;
  std::string reason_;
};

}  // namespace fieldline::region_tracking
