#include "tools/field_png/field_drawing.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace fieldline::field_png {
namespace {

using field::FieldModel;
using field::GoalColour;
using field::LineArc;
using field::LineSegment;
using field::Vec2;

// Polygon vertices are given with this many fractional bits for sub-pixel accuracy.
constexpr int kShift = 4;

class Canvas {
 public:
  Canvas(const FieldModel& model, double px_per_m) : scale_(px_per_m) {
    const Vec2 carpet = model.carpetHalfExtent();
    half_ = carpet + Vec2(kBarrierThickness, kBarrierThickness);
    image_ = cv::Mat(static_cast<int>(std::ceil(2 * half_.y() * scale_)),
                     static_cast<int>(std::ceil(2 * half_.x() * scale_)), CV_8UC3, kBarrier);
    fillRect(-carpet, carpet, kCarpet);
  }

  cv::Point toPixel(const Vec2& p) const {
    const double factor = scale_ * (1 << kShift);
    return {static_cast<int>(std::lround((p.x() + half_.x()) * factor)),
            static_cast<int>(std::lround((half_.y() - p.y()) * factor))};
  }

  void fillPolygons(const std::vector<std::vector<Vec2>>& contours, const cv::Scalar& colour) {
    std::vector<std::vector<cv::Point>> pixels;
    for (const auto& contour : contours) {
      auto& out = pixels.emplace_back();
      for (const Vec2& p : contour)
        out.push_back(toPixel(p));
    }
    cv::fillPoly(image_, pixels, colour, cv::LINE_AA, kShift);
  }

  void fillRect(const Vec2& lo, const Vec2& hi, const cv::Scalar& colour) {
    fillPolygons({{lo, Vec2(hi.x(), lo.y()), hi, Vec2(lo.x(), hi.y())}}, colour);
  }

  // The painted strip of a segment, extended by half its width at both ends so that lines
  // meeting at a corner close it.
  void drawSegment(const LineSegment& s) {
    const Vec2 along = (s.b - s.a).normalized() * (s.width / 2);
    const Vec2 across(-along.y(), along.x());
    fillPolygons(
        {{s.a - along - across, s.b + along - across, s.b + along + across, s.a - along + across}},
        kLine);
  }

  void drawArc(const LineArc& arc) {
    const int steps = std::max(16, static_cast<int>(arc.sweep * arc.radius * scale_ / 2));
    std::vector<Vec2> outer;
    std::vector<Vec2> inner;
    for (int k = 0; k <= steps; ++k) {
      const double angle = arc.start_angle + arc.sweep * k / steps;
      const Vec2 dir(std::cos(angle), std::sin(angle));
      outer.push_back(arc.centre + (arc.radius + arc.width / 2) * dir);
      inner.push_back(arc.centre + (arc.radius - arc.width / 2) * dir);
    }
    if (arc.sweep >= 2 * std::numbers::pi) {
      fillPolygons({outer, inner}, kLine);  // a ring: the inner contour is a hole
    } else {
      outer.insert(outer.end(), inner.rbegin(), inner.rend());
      fillPolygons({outer}, kLine);
    }
  }

  void fillCircle(const Vec2& centre, double radius, const cv::Scalar& colour) {
    std::vector<Vec2> ring;
    for (int k = 0; k < 32; ++k) {
      const double angle = 2 * std::numbers::pi * k / 32;
      ring.push_back(centre + radius * Vec2(std::cos(angle), std::sin(angle)));
    }
    fillPolygons({ring}, colour);
  }

  cv::Mat& image() { return image_; }

 private:
  double scale_;
  Vec2 half_;
  cv::Mat image_;
};

}  // namespace

cv::Scalar goalBgr(GoalColour colour) {
  switch (colour) {
    case GoalColour::kYellow:
      return {0, 215, 255};
    case GoalColour::kBlue:
      return {230, 110, 20};
    case GoalColour::kWhite:
      return {235, 235, 235};
  }
  return {0, 0, 0};
}

cv::Mat drawField(const FieldModel& model, double px_per_m) {
  Canvas canvas(model, px_per_m);
  for (const auto& goal : model.goals()) {
    const Vec2 across(-goal.outward.y(), goal.outward.x());
    const Vec2 back = goal.mouth_centre + goal.outward * goal.depth;
    const Vec2 a = goal.mouth_centre - across * (goal.width / 2);
    const Vec2 b = back + across * (goal.width / 2);
    canvas.fillRect(a.cwiseMin(b), a.cwiseMax(b), goalBgr(goal.colour));
  }
  for (const auto& segment : model.segments())
    canvas.drawSegment(segment);
  for (const auto& arc : model.arcs())
    canvas.drawArc(arc);
  for (const Vec2& mark : model.penaltyMarks()) {
    canvas.fillCircle(mark, model.dimensions().penalty_mark_diameter / 2, kLine);
  }
  return canvas.image();
}

cv::Point2d fieldToPixel(const FieldModel& model, double px_per_m, const Vec2& p) {
  const Vec2 half = model.carpetHalfExtent() + Vec2(kBarrierThickness, kBarrierThickness);
  return {(p.x() + half.x()) * px_per_m, (half.y() - p.y()) * px_per_m};
}

}  // namespace fieldline::field_png
