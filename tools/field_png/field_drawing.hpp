// Drawing of a field preset (fieldline-field-png and its test): green carpet up to the barrier,
// white lines at their true width, goals in their colour, penalty marks; field +x to the right,
// +y up. Plain library (OpenCV), no I/O.
#pragma once

#include <opencv2/core.hpp>

#include "common/field/field_model.hpp"

namespace fieldline::field_png {

// Colours of the drawing (BGR).
inline const cv::Scalar kCarpet(40, 140, 40);
inline const cv::Scalar kLine(255, 255, 255);
inline const cv::Scalar kBarrier(60, 60, 60);
cv::Scalar goalBgr(field::GoalColour colour);

// The barrier drawn outside the carpet, m.
inline constexpr double kBarrierThickness = 0.1;

// Draws `model` at `px_per_m`: the image spans the carpet plus the barrier.
cv::Mat drawField(const field::FieldModel& model, double px_per_m);

// Where a field point lies in an image drawField made of `model` at `px_per_m`: (column, row),
// fractional, pixel centres at integer coordinates (the pixel is the rounded value).
cv::Point2d fieldToPixel(const field::FieldModel& model, double px_per_m, const field::Vec2& p);

}  // namespace fieldline::field_png
