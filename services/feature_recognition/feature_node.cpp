#include "services/feature_recognition/feature_node.hpp"

#include <chrono>
#include <string>

#include "common/bus/channels.hpp"
#include "common/msg/field_features.hpp"
#include "common/msg/line_contours.hpp"

namespace fieldline::feature_recognition {

namespace {
constexpr std::int64_t kRateWindowUs = 1'000'000;
// The status's keys, made once: set after every message, those longer than the small-string
// buffer would each be allocated and freed every time (issue 32).
const std::string kRecognitionMs = "recognition_ms";
const std::string kDroppedSequencesTotal = "dropped_sequences_total";
const std::string kRejectedTotal = "model_check_rejected_total";
const std::string kRejectedCircleTotal = "model_check_rejected_circle_total";
const std::string kRejectedCornerTotal = "model_check_rejected_corner_total";
const std::string kCirclesPerS = "circles_per_s";
const std::string kCornersPerS = "corners_per_s";
const std::string kOtherFeaturesPerS = "other_features_per_s";
}  // namespace

FeatureNode::FeatureNode(bus::Node& node, const field::FieldModel& field, RecognitionParams params)
    : node_(node), recognizer_(field, params) {
  node_.subscribe(bus::channels::kVisionLines, [this](const line_contours_t& m) { onLines(m); });
  // Nothing to recognise without lines: WARN "VISION_LINES silent" rather than ok at 0 Hz (issue
  // 34, red-team finding 5). Region tracking sends them at 10-30 Hz.
  node_.requireInput(
      bus::channels::kVisionLines,
      bus::kRequiredRateFraction * bus::nominalRateHz(bus::channels::kVisionLines.name));
  node_.declareIo(featureIo());
}

bus::ProcessIo featureIo() {
  return bus::ProcessIo("feature_recognition")
      .reads(bus::channels::kVisionLines)
      .writes(bus::channels::kFieldFeatures);
}

void FeatureNode::onLines(const line_contours_t& m) {
  msg::fromMessage(m, points_);
  // Processing time is a measurement of this computer: steady_clock.
  const auto start = std::chrono::steady_clock::now();
  const InputCheck check = recognizer_.recognize(points_, features_);
  const double processing_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  ++frames_processed_;
  countInputErrors(check);
  countModelCheck();
  out_.header.utime = m.header.utime;
  msg::toMessage(features_, out_);
  node_.publish(bus::channels::kFieldFeatures, out_);
  updateRates(m.header.utime, features_);
  node_.setMetric(kRecognitionMs, processing_ms);
}

void FeatureNode::countInputErrors(const InputCheck& check) {
  if (check.errors() == 0) return;
  ++frames_with_errors_;
  const std::string text = "VISION_LINES: " + check.describe();
  // One error per kind present in the frame, so that each kind has its own count.
  if (check.too_many_points) node_.reportError("too_many_points", text);
  if (check.non_finite > 0) node_.reportError("non_finite_sequences", text);
  if (check.out_of_range > 0) node_.reportError("sequences_out_of_range", text);
  if (check.overlapping > 0) node_.reportError("overlapping_sequences", text);
  dropped_sequences_ += check.non_finite + check.out_of_range + check.overlapping;
  node_.setMetric(kDroppedSequencesTotal, static_cast<double>(dropped_sequences_));
}

void FeatureNode::countModelCheck() {
  for (const CheckedFeature& c : recognizer_.checked()) {
    if (c.accepted) continue;
    if (c.kind == perception::FeatureKind::kCentreCircle) {
      ++rejected_circles_;
    } else {
      ++rejected_corners_;
    }
  }
  node_.setMetric(kRejectedTotal, static_cast<double>(rejected_circles_ + rejected_corners_));
  node_.setMetric(kRejectedCircleTotal, static_cast<double>(rejected_circles_));
  node_.setMetric(kRejectedCornerTotal, static_cast<double>(rejected_corners_));
}

void FeatureNode::updateRates(std::int64_t utime, const perception::FieldFeatures& features) {
  Seen seen{utime, 0, 0, 0};
  for (const auto& f : features.features) {
    if (f.kind == perception::FeatureKind::kCentreCircle) {
      ++seen.circles;
    } else if (f.kind == perception::FeatureKind::kPenaltyCorner) {
      ++seen.corners;
    } else {
      ++seen.others;
    }
  }
  // A jump back in time (a replayed log) restarts the window.
  if (!recent_.empty() && utime < recent_.back().utime) recent_.clear();
  recent_.push_back(seen);
  while (!recent_.empty() && recent_.front().utime <= utime - kRateWindowUs)
    recent_.pop_front();
  int circles = 0, corners = 0, others = 0;
  for (const Seen& s : recent_) {
    circles += s.circles;
    corners += s.corners;
    others += s.others;
  }
  // Counts over the last second of exposure time = features per second.
  node_.setMetric(kCirclesPerS, circles);
  node_.setMetric(kCornersPerS, corners);
  node_.setMetric(kOtherFeaturesPerS, others);
}

}  // namespace fieldline::feature_recognition
