// Unseen lines (beyond the seed): the evidence of what is missing. The model check counts how
// many of the frame's points a pose puts on the field's lines; a pose can fit them well and still
// be wrong when it puts a line near the robot where the frame shows none. A stretch of model line
// counts as unseen only where the camera must have seen it: within `unseen_range`, with no point
// of the frame near it, and with a point seen further out on the same bearing (so no robot or
// goal stood in front of it; an occluder hides what lies behind it as well).
#pragma once

#include <cstdint>
#include <vector>

#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "services/feature_recognition/params.hpp"

namespace fieldline::feature_recognition {

class UnseenLines {
 public:
  // Samples the field's lines. Throws std::invalid_argument for unusable parameters.
  UnseenLines(const field::FieldModel& field, const RecognitionParams& params);

  // Indexes one frame's points (robot frame, m): which places have a point near them, and how
  // far out each bearing was seen.
  void index(const std::vector<geometry::Vec2>& points);
  // The longest stretch of one model line (m) that `robot` puts in clear view within range
  // with no indexed point near it.
  double longestUnseen(const geometry::Pose2& robot) const;
  // True if the pose's longest unseen stretch is short enough to keep it (always with the check
  // off, unseen_max_stretch < 0).
  bool accepts(double longest_unseen) const {
    return max_stretch_ < 0.0 || longest_unseen <= max_stretch_;
  }

 private:
  // The model's lines as samples at most 5 cm apart (field frame), element by element: samples
  // begin .. begin + intervals, within a circle (centre, radius); a segment also keeps its ends.
  struct Element {
    int begin = 0;
    int intervals = 0;
    double spacing = 0.0;  // m between its samples
    geometry::Vec2 centre = geometry::Vec2::Zero();
    double radius = 0.0;
    bool straight = false;
    bool closed = false;  // a full circle: its last sample is its first
    geometry::Vec2 a = geometry::Vec2::Zero(), b = geometry::Vec2::Zero();
  };
  std::vector<geometry::Vec2> samples_;
  std::vector<Element> elements_;
  double range_, min_range_, cover_, beyond_, max_stretch_;
  // Points near: a robot-frame map of cells, a cell near a point when its centre lies within
  // cover_ of the point's cell's centre (set to the frame's generation).
  double cell_;
  int side_ = 0;
  double half_extent_ = 0.0;
  std::vector<std::uint16_t> near_;
  std::vector<std::uint16_t> has_point_;  // cells already stamped this frame
  std::vector<int> stamp_;                // the stamp's half width per row
  std::uint16_t generation_ = 0;
  // The furthest point seen per bearing bin.
  int bins_ = 0;
  std::vector<float> furthest_;
  double inverse_cell_ = 1.0;
  // The map's cell of a robot-frame point; -1 outside the map.
  int cellOf(double x, double y) const {
    const double gx = (x + half_extent_) * inverse_cell_, gy = (y + half_extent_) * inverse_cell_;
    if (!(gx >= 0.0 && gy >= 0.0 && gx < side_ && gy < side_)) return -1;
    return static_cast<int>(gy) * side_ + static_cast<int>(gx);
  }
  int binOf(float x, float y) const;
  bool nearAt(double x, double y) const;
  bool clearTo(double x, double y, double range) const;
};

}  // namespace fieldline::feature_recognition
