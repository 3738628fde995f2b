// The feature_recognition process's bus side: VISION_LINES in, FIELD_FEATURES out for every
// message, stamped with the lines' utime (the exposure time). Unsound input is counted and
// reported; a frame refused whole still gets an (empty) FIELD_FEATURES so that consumers see
// every exposure.
//
// SERVICE_STATUS shows (besides the bus's own checks: a message with NaN/inf or sequences outside
// its points is rejected by the bus, counted in the channel's rejected_total and the "invalid"
// error kind, and gets no answer):
//   errors  non_finite_sequences, sequences_out_of_range, overlapping_sequences, too_many_points
//           (frames with such input; the sound sequences of the frame are still used)
//   metrics dropped_sequences_total (sequences dropped by the input check),
//           model_check_rejected_total, model_check_rejected_circle_total,
//           model_check_rejected_corner_total (features the model check refused: not errors,
//           the check doing its job), circles_per_s, corners_per_s, other_features_per_s,
//           recognition_ms
#pragma once

#include <cstdint>
#include <deque>

#include <fieldline/field_features_t.hpp>
#include <fieldline/line_contours_t.hpp>

#include "common/bus/node.hpp"
#include "common/field/field_model.hpp"
#include "services/feature_recognition/recognizer.hpp"

namespace fieldline::feature_recognition {

// What feature recognition reads and writes (fieldline-feature-recognition --print-io).
bus::ProcessIo featureIo();

class FeatureNode {
 public:
  // Subscribes VISION_LINES on `node`'s primary bus. `field` must outlive the node.
  FeatureNode(bus::Node& node, const field::FieldModel& field, RecognitionParams params = {});

  std::int64_t framesProcessed() const { return frames_processed_; }
  std::int64_t framesWithErrors() const { return frames_with_errors_; }
  std::int64_t droppedSequences() const { return dropped_sequences_; }
  std::int64_t modelCheckRejections() const { return rejected_circles_ + rejected_corners_; }

 private:
  void onLines(const line_contours_t& m);
  void updateRates(std::int64_t utime, const perception::FieldFeatures& features);
  void countInputErrors(const InputCheck& check);
  void countModelCheck();

  bus::Node& node_;
  FeatureRecognizer recognizer_;
  perception::LinePoints points_;
  perception::FieldFeatures features_;
  field_features_t out_{};
  std::int64_t frames_processed_ = 0;
  std::int64_t frames_with_errors_ = 0;
  std::int64_t dropped_sequences_ = 0;
  std::int64_t rejected_circles_ = 0;
  std::int64_t rejected_corners_ = 0;
  // Exposure times and feature counts by kind of the last second, for the rates in the status.
  struct Seen {
    std::int64_t utime;
    int circles, corners, others;
  };
  std::deque<Seen> recent_;
};

}  // namespace fieldline::feature_recognition
