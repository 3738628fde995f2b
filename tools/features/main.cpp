// fieldline-features: feature recognition on line points from a file, for people with real
// data. Reads points in the robot frame (x forward, y left, m; "x,y" per line; a blank line
// between sequences), prints the features and pose hypotheses as JSON, and optionally draws the
// points, the recogniser's pieces and fitted features (robot frame, left) and the hypotheses on
// the field (right).
//
//   fieldline-features --points frame.csv --field msl --png frame.png
#include <cmath>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/cli/cli.hpp"
#include "common/field/field_model.hpp"
#include "common/perception/line_points_csv.hpp"
#include "services/feature_recognition/recognizer.hpp"

namespace {

using namespace fieldline;
using geometry::Vec2;
using perception::FeatureKind;

const char* kindName(FeatureKind kind) {
  switch (kind) {
    case FeatureKind::kCentreCircle:
      return "centre_circle";
    case FeatureKind::kPenaltyCorner:
      return "penalty_corner";
    case FeatureKind::kFieldCorner:
      return "l_corner";
    case FeatureKind::kTJunction:
      return "t_junction";
    case FeatureKind::kStraightLine:
      return "straight_line";
    case FeatureKind::kGoal:
      return "goal";
  }
  return "unknown";
}

std::string number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.4f", v);
  return buffer;
}

void printJson(const perception::FieldFeatures& f, const feature_recognition::InputCheck& check) {
  std::cout << "{\n  \"input_errors\": \"" << check.describe() << "\",\n  \"features\": [";
  for (std::size_t i = 0; i < f.features.size(); ++i) {
    const auto& x = f.features[i];
    std::cout << (i ? "," : "") << "\n    {\"kind\": \"" << kindName(x.kind)
              << "\", \"x\": " << number(x.local.x) << ", \"y\": " << number(x.local.y)
              << ", \"phi\": " << number(x.local.phi) << ", \"quality\": " << number(x.quality)
              << "}";
  }
  std::cout << "\n  ],\n  \"hypotheses\": [";
  for (std::size_t i = 0; i < f.hypotheses.size(); ++i) {
    const auto& h = f.hypotheses[i];
    std::cout << (i ? "," : "") << "\n    {\"feature\": " << h.feature
              << ", \"x\": " << number(h.pose.x) << ", \"y\": " << number(h.pose.y)
              << ", \"phi\": " << number(h.pose.phi) << ", \"sigma_xy\": " << number(h.sigma_xy)
              << ", \"sigma_phi\": " << number(h.sigma_phi) << "}";
  }
  std::cout << "\n  ]\n}\n";
}

// A panel mapping metres to pixels: centre, metres per half side, +x right (field) or +x up
// (robot frame, forward up).
struct Panel {
  cv::Mat image;
  cv::Point origin;
  double scale;
  bool forward_up;
  cv::Point px(const Vec2& p) const {
    if (forward_up) {
      return {origin.x - static_cast<int>(std::lround(p.y() * scale)),
              origin.y - static_cast<int>(std::lround(p.x() * scale))};
    }
    return {origin.x + static_cast<int>(std::lround(p.x() * scale)),
            origin.y - static_cast<int>(std::lround(p.y() * scale))};
  }
};

void drawPng(const std::string& path, const feature_recognition::FeatureRecognizer& r,
             const perception::LinePoints& points, const perception::FieldFeatures& features) {
  const field::FieldModel& field = r.field();
  const Vec2 half = field.carpetHalfExtent();
  const double scale = 40.0;
  const int robot_side = 600;
  const int field_w = static_cast<int>(2 * half.x() * scale * 0.5);
  const int field_h = static_cast<int>(2 * half.y() * scale * 0.5);
  cv::Mat image(std::max(robot_side, field_h), robot_side + field_w, CV_8UC3,
                cv::Scalar(30, 30, 30));
  Panel local{image(cv::Rect(0, 0, robot_side, robot_side)),
              {robot_side / 2, robot_side / 2},
              robot_side / 14.0,
              true};
  Panel map{image(cv::Rect(robot_side, 0, field_w, field_h)),
            {field_w / 2, field_h / 2},
            scale * 0.5,
            false};
  local.image.setTo(cv::Scalar(35, 80, 35));
  map.image.setTo(cv::Scalar(35, 80, 35));
  const cv::Scalar white(230, 230, 230), grey(120, 120, 120);
  // Robot-frame panel: range rings every metre, raw points, pieces, groups, features.
  for (int m = 1; m <= 7; ++m)
    cv::circle(local.image, local.origin, int(m * local.scale), {50, 95, 50});
  cv::arrowedLine(local.image, local.px({0, 0}), local.px({0.6, 0}), white, 2);
  for (const auto& p : points.points) {
    if (std::isfinite(p.x) && std::isfinite(p.y)) {
      cv::circle(local.image, local.px({p.x, p.y}), 1, grey, -1);
    }
  }
  const auto& c = r.contours();
  for (const auto& arc : r.classified().arcs) {
    const auto& piece = c.pieces[arc.piece];
    for (int i = piece.begin + 1; i < piece.end; ++i) {
      cv::line(local.image, local.px(c.points[i - 1]), local.px(c.points[i]), {0, 160, 255}, 2);
    }
  }
  for (const auto& groups : r.structure().groups) {
    for (const auto& g : groups) {
      cv::line(local.image, local.px(g.line.start()), local.px(g.line.end()), {255, 255, 0}, 1,
               cv::LINE_AA);
    }
  }
  if (r.circle().found) {
    cv::circle(local.image, local.px(r.circle().fit.centre),
               static_cast<int>(r.circle().fit.radius * local.scale), {255, 0, 255}, 2,
               cv::LINE_AA);
  }
  for (const auto& f : features.features) {
    const Vec2 p(f.local.x, f.local.y);
    const Vec2 d(std::cos(f.local.phi), std::sin(f.local.phi));
    cv::Scalar colour = f.kind == FeatureKind::kPenaltyCorner  ? cv::Scalar(0, 0, 255)
                        : f.kind == FeatureKind::kCentreCircle ? cv::Scalar(255, 0, 255)
                        : f.kind == FeatureKind::kStraightLine ? cv::Scalar(255, 255, 0)
                                                               : cv::Scalar(0, 255, 255);
    cv::circle(local.image, local.px(p), 4, colour, -1);
    cv::arrowedLine(local.image, local.px(p), local.px(p + 0.5 * d), colour, 2);
  }
  // Field panel: the model's lines and the hypotheses.
  for (const auto& s : field.segments())
    cv::line(map.image, map.px(s.a), map.px(s.b), white, 1);
  for (const auto& arc : field.arcs()) {
    for (int i = 0; i < 48; ++i) {
      cv::line(map.image, map.px(arc.pointAt(arc.start_angle + arc.sweep * i / 48)),
               map.px(arc.pointAt(arc.start_angle + arc.sweep * (i + 1) / 48)), white, 1);
    }
  }
  for (const auto& h : features.hypotheses) {
    const Vec2 p = h.pose.position();
    cv::circle(map.image, map.px(p), std::max(3, int(h.sigma_xy * map.scale)), {0, 0, 255}, 2);
    cv::arrowedLine(map.image, map.px(p),
                    map.px(p + 0.8 * Vec2(std::cos(h.pose.phi), std::sin(h.pose.phi))), {0, 0, 255},
                    2);
  }
  cv::imwrite(path, image);
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Feature recognition on line points from a CSV file (robot frame: x forward, y left, m; "
      "one point per line; a blank line between sequences). Prints features and pose "
      "hypotheses as JSON."};
  std::string points_path, field_name = "msl", png;
  app.add_option("--points", points_path, "CSV file of line points")->required();
  app.add_option("--field", field_name, "Field preset (msl, fu2004) or YAML file")
      ->capture_default_str();
  app.add_option("--png", png, "Draw points, features and hypotheses to this PNG");
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    // --help exits 0; bad arguments exit 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    const field::FieldModel field = field::loadFieldPreset(field_name);
    const perception::LinePoints points = perception::readLinePointsCsvFile(points_path);
    feature_recognition::FeatureRecognizer recognizer(field);
    perception::FieldFeatures features;
    const auto check = recognizer.recognize(points, features);
    printJson(features, check);
    if (!png.empty()) drawPng(png, recognizer, points, features);
  } catch (const std::exception& e) {
    std::cerr << "fieldline-features: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
