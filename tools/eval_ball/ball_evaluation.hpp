// The ball detector's must-show of issue 12 on rendered frames: a robot drives across the field
// while the ball lies at random places (sometimes absent), orange objects stand off the field
// and people in red at the side; every frame's detection is scored against the truth.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "services/camera/realism.hpp"
#include "services/region_tracking/frame_processor.hpp"
#include "tools/sim_frames/sim_frames.hpp"

namespace fieldline::eval_ball {

struct BallEvalOptions {
  int frames = 1000;
  std::uint32_t seed = 1;
  // The clutter changes place every this many frames, and the ball takes a new speed and
  // direction; the robot drives on.
  int segment_frames = 30;
  // The ball rolls at up to this speed, m/s (bouncing off the lines), in each segment toward a
  // place 0.5-5.5 m from where the robot will be at the segment's end, so that it comes near,
  // leaves and comes into view as a real ball does; it is always somewhere on the field.
  double max_ball_speed = 3.0;
  // Orange objects off the field (0.4 m beyond the lines up to 1.5 m beyond the carpet) and
  // people in red beyond the side lines, per segment.
  int orange_objects = 3;
  int people = 2;
  // Found within this distance of a visible ball's true place counts as found; farther is a
  // false ball.
  double false_ball_distance = 0.5;
  // Visible: the ball within this distance of the robot.
  double visible_within = 4.0;
  // Realism knobs for the renderer (identity by default).
  camera::RealismParams realism;
  // Where a ball can be (issue 30): the detector gets the field and the robot's pose as fusion
  // would give it, the truth moved by a random error of this many metres (and a tenth of it in
  // radians); false: the image alone.
  bool field_check = true;
  double pose_sigma_m = 0.02;
  // The colour table to track with (a venue's calibrated one); null: the camera preset's.
  const camera::ColourTable* table = nullptr;
};

struct BallEvalResult {
  int frames = 0;
  // Frames reporting a ball farther than false_ball_distance from the true ball.
  int false_balls = 0;
  // Frames with the ball visible within visible_within (0.4 m up to it, its whole image inside
  // the frame), and those of them reporting it.
  int visible_frames = 0;
  // Frames with the ball within reach but its image cut by the frame's border (not counted as
  // visible; the detector refuses cut candidates), and those of them reporting it anyway.
  int cut_frames = 0, cut_found = 0;
  int found_frames = 0;
  // Errors of the found ones (robot frame, m), and how many were within 5 cm.
  std::vector<double> errors;
  int within_5cm = 0;
  // Frames reporting a ball beyond the field's lines (outer edges) at the robot's true pose.
  int outside_field = 0;
  // Candidates looked at and refused, summed over all frames.
  long candidates = 0, rejected = 0;
  // Frames with the ball visible but not found: without any ball-coloured candidate (the
  // tracker did not see it), and the refusals among their candidates by reason (BallReject).
  int missed_without_candidate = 0;
  std::array<int, region_tracking::kBallRejectCount> missed_reasons{};
  // Found / visible frames per metre of distance (0-1, 1-2, 2-3, 3-4 m).
  std::array<int, 4> visible_by_metre{}, found_by_metre{};
  // The first few false balls: frame number and where (robot frame).
  struct False {
    int frame;
    double x, y;
    double truth_distance;  // to the true ball, or -1 without one
  };
  std::vector<False> first_false;

  double foundRate() const {
    return visible_frames > 0 ? static_cast<double>(found_frames) / visible_frames : 0.0;
  }
  double errorQuantile(double q) const;
};

// Where the ball is in each frame of the robot's drive `poses` (field frame, m; deterministic
// per seed).
std::vector<camera::Vec2> ballPath(const BallEvalOptions& options, const field::FieldModel& field,
                                   const std::vector<geometry::Pose2>& poses);

// The scene of frame `frame` (deterministic per seed and frame): pose, ball, clutter.
camera::SimScene sceneFor(const BallEvalOptions& options, const field::FieldModel& field,
                          const std::vector<geometry::Pose2>& poses,
                          const std::vector<camera::Vec2>& balls, int frame);

// Renders and tracks options.frames frames with `vision` parameters and scores the ball.
BallEvalResult evaluateBall(region_tracking::SimCamera& sim,
                            const region_tracking::VisionParams& vision,
                            const BallEvalOptions& options);

// "frames=... false_balls=... found_rate=... err_median_m=... err_p95_m=..." and the rest.
std::string summaryLine(const BallEvalResult& result);
// Found rate per metre of distance and why visible balls were missed.
std::string missLine(const BallEvalResult& result);

}  // namespace fieldline::eval_ball
