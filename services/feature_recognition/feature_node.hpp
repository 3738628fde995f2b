// The feature_recognition process's bus side: VISION_LINES in, FIELD_FEATURES out for every
// message, stamped with the lines' utime (the exposure time). Unsound input is counted and
// reported; a frame refused whole still gets an (empty) FIELD_FEATURES so that consumers see
// every exposure.
#pragma once

#include <cstdint>
#include <deque>

#include <fieldline/field_features_t.hpp>
#include <fieldline/line_contours_t.hpp>

#include "common/bus/node.hpp"
#include "common/field/field_model.hpp"
#include "services/feature_recognition/recognizer.hpp"

namespace fieldline::feature_recognition {

class FeatureNode {
 public:
  // Subscribes VISION_LINES on `node`'s primary bus. `field` must outlive the node.
  FeatureNode(bus::Node& node, const field::FieldModel& field, RecognitionParams params = {});

  std::int64_t framesProcessed() const { return frames_processed_; }
  std::int64_t framesWithErrors() const { return frames_with_errors_; }

 private:
  void onLines(const line_contours_t& m);
  void updateRates(std::int64_t utime, const perception::FieldFeatures& features);

  bus::Node& node_;
  FeatureRecognizer recognizer_;
  perception::LinePoints points_;
  perception::FieldFeatures features_;
  field_features_t out_{};
  std::int64_t frames_processed_ = 0;
  std::int64_t frames_with_errors_ = 0;
  // Exposure times and feature counts by kind of the last second, for the rates in the status.
  struct Seen {
    std::int64_t utime;
    int circles, corners, others;
  };
  std::deque<Seen> recent_;
};

}  // namespace fieldline::feature_recognition
