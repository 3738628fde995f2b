// fieldline-localize: layer 2 (and, without a guess, the coarse global search) on one set of line
// points given in the robot frame; prints the pose, its covariance and the match cost as JSON.
//
//   fieldline-localize --points frame.csv --field msl --guess 1.0,0.5,0.3 --png found.png
//
// Exit codes: 0 a valid pose, 1 no pose fits the points, 2 bad arguments or input.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/bus/cli.hpp"
#include "common/field/field_model.hpp"
#include "services/fusion/line_matcher.hpp"
#include "services/fusion/points_csv.hpp"

namespace {

using fieldline::field::FieldModel;
using fieldline::field::Vec2;
using fieldline::fusion::PoseCorrection;
using fieldline::geometry::Pose2;

void printPose(const PoseCorrection& c, const char* indent) {
  std::printf("%s\"pose\": {\"x\": %.4f, \"y\": %.4f, \"phi\": %.5f},\n", indent, c.pose.x,
              c.pose.y, c.pose.phi);
  std::printf("%s\"covariance\": [", indent);
  for (int r = 0; r < 3; ++r) {
    std::printf("%s[%.6g, %.6g, %.6g]", r ? ", " : "", c.covariance(r, 0), c.covariance(r, 1),
                c.covariance(r, 2));
  }
  std::printf("],\n");
  std::printf(
      "%s\"cost_m\": %.5f, \"valid\": %s, \"points_used\": %d, \"inliers\": %d, "
      "\"iterations\": %d",
      indent, c.cost, c.valid ? "true" : "false", c.points_used, c.inliers, c.iterations);
}

// The field (carpet, lines as thin polylines) with the points at `pose` in red and the robot as
// a circle with a heading tick; field +x to the right, +y up.
void drawPng(const FieldModel& field, const std::vector<fieldline::perception::LinePoint>& points,
             const Pose2& pose, const std::string& path) {
  const double scale = 40.0;  // px per m
  const Vec2 half = field.carpetHalfExtent() + Vec2(0.1, 0.1);
  cv::Mat image(static_cast<int>(std::ceil(2 * half.y() * scale)),
                static_cast<int>(std::ceil(2 * half.x() * scale)), CV_8UC3,
                cv::Scalar(40, 140, 40));
  auto pixel = [&](const Vec2& p) {
    return cv::Point(static_cast<int>(std::lround((p.x() + half.x()) * scale)),
                     static_cast<int>(std::lround((half.y() - p.y()) * scale)));
  };
  const cv::Scalar white(255, 255, 255);
  for (const auto& s : field.segments())
    cv::line(image, pixel(s.a), pixel(s.b), white, 2, cv::LINE_AA);
  for (const auto& arc : field.arcs()) {
    const int steps = 64;
    for (int k = 0; k < steps; ++k) {
      const double a0 = arc.start_angle + arc.sweep * k / steps;
      const double a1 = arc.start_angle + arc.sweep * (k + 1) / steps;
      cv::line(image, pixel(arc.pointAt(a0)), pixel(arc.pointAt(a1)), white, 2, cv::LINE_AA);
    }
  }
  for (const auto& q : points) {
    if (!(std::isfinite(q.x) && std::isfinite(q.y))) continue;
    cv::circle(image, pixel(fieldline::geometry::pointRobotToField(pose, Vec2(q.x, q.y))), 2,
               cv::Scalar(40, 40, 230), cv::FILLED, cv::LINE_AA);
  }
  const cv::Scalar robot(230, 120, 20);
  cv::circle(image, pixel(pose.position()), static_cast<int>(0.25 * scale), robot, 2, cv::LINE_AA);
  cv::line(image, pixel(pose.position()),
           pixel(pose.position() + 0.4 * Vec2(std::cos(pose.phi), std::sin(pose.phi))), robot, 2,
           cv::LINE_AA);
  if (!cv::imwrite(path, image)) throw std::runtime_error("cannot write " + path);
}

// The JSON answer: the best pose first, then the alternatives (empty results: not valid).
void printResults(const FieldModel& field, const std::string& method, std::size_t num_points,
                  bool from_guess, const std::vector<PoseCorrection>& results) {
  std::printf("{\n  \"field\": \"%s\", \"method\": \"%s\", \"points\": %zu, \"source\": \"%s\",\n",
              field.name().c_str(), method.c_str(), num_points,
              from_guess ? "guess" : "global_search");
  if (results.empty()) {
    std::printf("  \"valid\": false\n}\n");
    return;
  }
  printPose(results[0], "  ");
  std::printf(",\n  \"alternatives\": [");
  for (std::size_t k = 1; k < results.size(); ++k) {
    std::printf("%s\n    {\n", k > 1 ? "," : "");
    printPose(results[k], "      ");
    std::printf("\n    }");
  }
  std::printf("]\n}\n");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Localizes from one frame's line points (robot frame: x forward, y left, m; CSV \"x,y\" one "
      "point per line, blank line between sequences). With --guess: layer 2 corrects the guess. "
      "Without: a coarse search over the whole field, best candidates refined (the field's "
      "symmetric twin fits as well and is listed among the alternatives). Prints JSON."};
  std::string points_path, field_name = "msl", guess_text, png, method = "least_squares", cache;
  app.add_option("--points", points_path, "CSV file of line points in the robot frame")->required();
  app.add_option("--field", field_name, "field preset (msl, fu2004) or a field YAML file")
      ->capture_default_str();
  app.add_option("--guess", guess_text, "pose guess x,y,phi (m, m, rad), field frame");
  app.add_option("--method", method, "layer 2 method")
      ->check(CLI::IsMember({"least_squares", "force_field"}))
      ->capture_default_str();
  app.add_option("--png", png, "draw the points at the found pose on the field to this PNG");
  app.add_option("--cache", cache, "directory for the distance grid cache (default: none)");
  FIELDLINE_PARSE(app, argc, argv);

  try {
    const FieldModel field = fieldline::field::loadFieldPreset(field_name);
    const fieldline::perception::LinePoints points =
        fieldline::fusion::readLinePointsCsvFile(points_path);
    fieldline::fusion::MatcherParams params;
    params.method = method == "force_field" ? fieldline::fusion::MatchMethod::kForceField
                                            : fieldline::fusion::MatchMethod::kRobustLeastSquares;
    std::optional<Pose2> guess;
    if (!guess_text.empty()) {
      const std::vector<double> g = fieldline::bus::parseNumberList(guess_text, 3, "--guess");
      guess = Pose2{g[0], g[1], g[2]};
    }
    const fieldline::fusion::LineMatcher matcher(field, params, cache);

    std::vector<PoseCorrection> results;
    if (guess) {
      results.push_back(matcher.correct(points.points, *guess));
    } else {
      results = matcher.globalSearch(points.points);
    }
    printResults(field, method, points.points.size(), guess.has_value(), results);
    if (results.empty()) return 1;
    if (!png.empty()) drawPng(field, points.points, results[0].pose, png);
    return results[0].valid ? 0 : 1;
  } catch (const std::invalid_argument& e) {
    std::cerr << "fieldline-localize: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "fieldline-localize: " << e.what() << "\n";
    return 2;
  }
}
