// fieldline-field-png: draws a field preset (green carpet up to the barrier, white lines at their
// true width, goals in their colour, penalty marks) to a PNG, field +x to the right, +y up.
//
//   fieldline-field-png --field msl --out docs/images/field_msl.png --px-per-m 30
#include <algorithm>
#include <cmath>
#include <iostream>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/config/config.hpp"
#include "common/field/field_model.hpp"

namespace {

using fieldline::field::FieldModel;
using fieldline::field::GoalColour;
using fieldline::field::LineArc;
using fieldline::field::LineSegment;
using fieldline::field::Vec2;

// Polygon vertices are given with this many fractional bits for sub-pixel accuracy.
constexpr int kShift = 4;
constexpr double kBarrierThickness = 0.1;  // m, drawn outside the carpet

const cv::Scalar kCarpet(40, 140, 40);
const cv::Scalar kLine(255, 255, 255);
const cv::Scalar kBarrier(60, 60, 60);

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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Draws a field preset to a PNG: green carpet up to the barrier, white lines at their true "
      "width, goals in their colour. Field +x points right, +y up."};
  std::string field = "msl";
  std::string out;
  double px_per_m = 40.0;
  app.add_option("--field", field, "Preset name (config/field/NAME.yaml) or path to a YAML file")
      ->capture_default_str();
  app.add_option("--out", out, "Output PNG file")->required();
  app.add_option("--px-per-m", px_per_m, "Pixels per metre")
      ->check(CLI::Range(5.0, 500.0))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  std::optional<FieldModel> model;
  fieldline::config::runOrExit([&] { model.emplace(fieldline::field::loadFieldPreset(field)); });
  const cv::Mat image = drawField(*model, px_per_m);
  bool written = false;
  try {
    written = cv::imwrite(out, image, {cv::IMWRITE_PNG_COMPRESSION, 9});
  } catch (const cv::Exception& e) {
    std::cerr << "cannot write " << out << ": " << e.what() << "\n";
    return 1;
  }
  if (!written) {
    std::cerr << "cannot write " << out << "\n";
    return 1;
  }
  std::cout << "wrote " << out << " (" << image.cols << " x " << image.rows << " px, field '"
            << model->name() << "')\n";
  return 0;
}
