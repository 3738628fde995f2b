// fieldline-localize: layer 2 (and, without a guess, the coarse global search) on one set of line
// points given in the robot frame; prints the pose, its covariance and the match cost as JSON.
//
//   fieldline-localize --points frame.csv --field msl --guess 1.0,0.5,0.3 --png found.png
//
// Exit codes: 0 a valid pose, 1 no pose fits the points (the reason on stderr and in the JSON),
// 2 bad arguments or input (a NaN, a coordinate beyond 1000 m, a directory, an empty file).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/bus/cli.hpp"
#include "common/cli/cli.hpp"
#include "common/field/field_model.hpp"
#include "common/perception/line_points_csv.hpp"
#include "services/fusion/line_matcher.hpp"

namespace cli = fieldline::cli;

namespace {

using fieldline::field::FieldModel;
using fieldline::field::Vec2;
using fieldline::fusion::PoseCorrection;
using fieldline::geometry::Pose2;

void printPoseOnly(const Pose2& pose, const char* key, const char* indent) {
  std::printf("%s\"%s\": {\"x\": %.4f, \"y\": %.4f, \"phi\": %.5f}", indent, key, pose.x, pose.y,
              pose.phi);
}

void printPose(const PoseCorrection& c, const char* indent) {
  printPoseOnly(c.pose, "pose", indent);
  std::printf(",\n");
  // Standard deviations along the axes and along / across the position ellipse.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> ellipse(c.covariance.topLeftCorner<2, 2>());
  const Eigen::Vector2d major = ellipse.eigenvectors().col(1);
  std::printf(
      "%s\"sigma\": {\"x_m\": %.4f, \"y_m\": %.4f, \"phi_rad\": %.5f, \"major_m\": %.4f, "
      "\"minor_m\": %.4f, \"major_direction_rad\": %.4f},\n",
      indent, std::sqrt(c.covariance(0, 0)), std::sqrt(c.covariance(1, 1)),
      std::sqrt(c.covariance(2, 2)), std::sqrt(std::max(0.0, ellipse.eigenvalues()(1))),
      std::sqrt(std::max(0.0, ellipse.eigenvalues()(0))), std::atan2(major.y(), major.x()));
  std::printf("%s\"covariance\": [", indent);
  for (int r = 0; r < 3; ++r) {
    std::printf("%s[%.6g, %.6g, %.6g]", r ? ", " : "", c.covariance(r, 0), c.covariance(r, 1),
                c.covariance(r, 2));
  }
  std::printf("],\n");
  std::printf(
      "%s\"cost_m\": %.5f, \"valid\": %s, \"points_used\": %d, \"inliers\": %d, "
      "\"iterations\": %d,\n",
      indent, c.cost, c.valid ? "true" : "false", c.points_used, c.inliers, c.iterations);
  if (!c.valid) std::printf("%s\"invalid_reason\": \"%s\",\n", indent, c.invalid_reason.c_str());
  std::printf(
      "%s\"residual_rms_m\": %.4f, \"residual_inflation\": %.2f, \"independent_points\": %.1f, "
      "\"shape_widening\": %.2f",
      indent, c.residual_rms_m, c.residual_inflation, c.independent_points, c.shape_widening);
}

bool isTwin(const Pose2& a, const Pose2& b) {
  return std::hypot(a.x + b.x, a.y + b.y) < 0.5 &&
         std::abs(fieldline::geometry::angleDiff(a.phi + std::numbers::pi, b.phi)) < 0.35;
}

// The best other answer to name: the answers of the global search after the first, and the
// first answer's own local runner-up (an alias along the lines).
struct RunnerUp {
  Pose2 pose;
  double cost = 0.0;
  const char* kind = "alias";
};

std::optional<RunnerUp> bestOther(const std::vector<PoseCorrection>& results, bool twins) {
  std::optional<RunnerUp> best;
  const auto offer = [&](const Pose2& pose, double cost) {
    const bool twin = isTwin(results[0].pose, pose);
    if (twin != twins) return;
    if (!best || cost < best->cost) best = RunnerUp{pose, cost, twin ? "twin" : "alias"};
  };
  for (std::size_t k = 1; k < results.size(); ++k)
    offer(results[k].pose, results[k].cost);
  if (results[0].has_runner_up) offer(results[0].runner_up, results[0].runner_up_cost);
  return best;
}

void printRunnerUp(const char* key, const std::optional<RunnerUp>& r, double cost) {
  if (!r) return;
  std::printf(",\n  \"%s\": {\"kind\": \"%s\", ", key, r->kind);
  printPoseOnly(r->pose, "pose", "");
  std::printf(", \"cost_m\": %.5f, \"cost_difference_m\": %.5f}", r->cost, r->cost - cost);
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

// The JSON answer: the best pose first, the runner-up (the best other answer: the symmetric twin
// or an alias), then the alternatives (empty results: not valid).
void printResults(const FieldModel& field, const std::string& method, std::size_t num_points,
                  bool from_guess, const std::vector<PoseCorrection>& results,
                  const std::string& reason, const PoseCorrection* rejected) {
  std::printf("{\n  \"field\": \"%s\", \"method\": \"%s\", \"points\": %zu, \"source\": \"%s\",\n",
              field.name().c_str(), method.c_str(), num_points,
              from_guess ? "guess" : "global_search");
  if (results.empty()) {
    std::printf("  \"valid\": false, \"invalid_reason\": \"%s\"", reason.c_str());
    if (rejected && rejected->iterations > 0) {
      // The best the search found, for a user to judge (another field? wrong units?).
      std::printf(",\n  \"best_rejected\": {\n");
      printPose(*rejected, "    ");
      std::printf("\n  }");
    }
    std::printf("\n}\n");
    return;
  }
  const PoseCorrection& best = results[0];
  printPose(best, "  ");
  const std::optional<RunnerUp> twin = bestOther(results, true);
  const std::optional<RunnerUp> alias = bestOther(results, false);
  std::optional<RunnerUp> runner_up = twin;
  if (alias && (!runner_up || alias->cost < runner_up->cost)) runner_up = alias;
  printRunnerUp("runner_up", runner_up, best.cost);
  if (runner_up && alias && runner_up->kind != alias->kind) {
    printRunnerUp("best_alias", alias, best.cost);
  }
  if (best.has_runner_up) {
    std::printf(",\n  \"local_runner_up_delta\": %.3f", best.runner_up_delta);
  }
  std::printf(",\n  \"alternatives\": [");
  for (std::size_t k = 1; k < results.size(); ++k) {
    std::printf("%s\n    {\n", k > 1 ? "," : "");
    printPose(results[k], "      ");
    std::printf("\n    }");
  }
  std::printf("]\n}\n");
}

// One field, or several (comma-separated) of which the best fitting is answered: the points'
// field may not be known.
std::vector<std::string> fieldNames(const std::string& field_name) {
  std::vector<std::string> field_names;
  for (std::size_t start = 0; start <= field_name.size();) {
    const std::size_t comma = std::min(field_name.find(',', start), field_name.size());
    if (comma > start) field_names.push_back(field_name.substr(start, comma - start));
    start = comma + 1;
  }
  if (field_names.empty()) throw std::invalid_argument("--field: no field named");
  return field_names;
}

// A field's answer: layer 2's results (from the guess or the global search) and the best pose the
// search rejected.
struct FieldAnswer {
  std::vector<PoseCorrection> results;
  PoseCorrection rejected;
};

// Validity first, then the cost.
std::pair<int, double> costOf(const FieldAnswer& a) {
  if (!a.results.empty()) return std::pair{a.results[0].valid ? 0 : 1, a.results[0].cost};
  return std::pair{1, a.rejected.iterations > 0 ? a.rejected.cost : 1e9};
}

// Each field's answer; the index of the one with the lowest cost among the valid ones (else among
// all), which is printed in full.
std::size_t answerEachField(const std::vector<FieldModel>& fields,
                            const fieldline::perception::LinePoints& points,
                            const fieldline::fusion::MatcherParams& params,
                            const std::optional<Pose2>& guess, const std::string& cache,
                            std::vector<FieldAnswer>& answers) {
  std::size_t best = 0;
  for (std::size_t k = 0; k < fields.size(); ++k) {
    const fieldline::fusion::LineMatcher matcher(fields[k], params, cache);
    if (guess) {
      answers[k].results.push_back(matcher.correct(points.points, *guess));
    } else {
      answers[k].results = matcher.globalSearch(points.points, {}, 0, &answers[k].rejected);
    }
    if (costOf(answers[k]) < costOf(answers[best])) best = k;
  }
  if (fields.size() > 1) {
    std::fprintf(stderr, "fields tried (best first by validity, then cost):\n");
    for (std::size_t k = 0; k < fields.size(); ++k) {
      const auto [invalid, cost] = costOf(answers[k]);
      std::fprintf(stderr, "  %-16s %s  cost %.3f m%s\n", fields[k].name().c_str(),
                   invalid ? "not valid" : "valid    ", cost, k == best ? "  <- answered" : "");
    }
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Localizes from one frame's line points (robot frame: x forward, y left, m; CSV \"x,y\" one "
      "point per line, blank line between sequences). With --guess: layer 2 corrects the guess. "
      "Without: a coarse search over the whole field, best candidates refined (the field's "
      "symmetric twin fits as well and is listed among the alternatives). Prints JSON."};
  std::string points_path, field_name = "msl", guess_text, png, method = "least_squares", cache;
  std::string units = "m";
  app.add_option("--points", points_path, "CSV file of line points in the robot frame")->required();
  app.add_option("--units", units, "units of the CSV's coordinates")
      ->check(cli::IsMember({"m", "mm"}))
      ->capture_default_str();
  app.add_option("--field", field_name,
                 "field preset (msl, fu2004, cnc_lab, ...) or a field YAML file; several, "
                 "comma-separated: each is tried and the best fitting answered")
      ->capture_default_str();
  app.add_option("--guess", guess_text, "pose guess x,y,phi (m, m, rad), field frame");
  app.add_option("--method", method, "layer 2 method")
      ->check(cli::IsMember({"least_squares", "force_field"}))
      ->capture_default_str();
  app.add_option("--png", png, "draw the points at the found pose on the field to this PNG");
  app.add_option("--cache", cache, "directory for the distance grid cache (default: none)");
  FIELDLINE_PARSE(app, argc, argv);

  try {
    const std::vector<std::string> field_names = fieldNames(field_name);
    std::vector<FieldModel> fields;
    for (const std::string& name : field_names)
      fields.push_back(fieldline::field::loadFieldPreset(name));
    const fieldline::perception::LinePoints points =
        fieldline::perception::readLinePointsCsvFile(points_path, units == "mm" ? 0.001 : 1.0);
    fieldline::fusion::MatcherParams params = fieldline::fusion::withCalibratedCamera({});
    params.method = method == "force_field" ? fieldline::fusion::MatchMethod::kForceField
                                            : fieldline::fusion::MatchMethod::kRobustLeastSquares;
    std::optional<Pose2> guess;
    if (!guess_text.empty()) {
      const std::vector<double> g = fieldline::bus::parseNumberList(guess_text, 3, "--guess");
      guess = Pose2{g[0], g[1], g[2]};
    }

    std::vector<FieldAnswer> answers(fields.size());
    const std::size_t best = answerEachField(fields, points, params, guess, cache, answers);
    const FieldModel& field = fields[best];
    const std::vector<PoseCorrection>& results = answers[best].results;
    char reason_text[256];
    std::snprintf(reason_text, sizeof reason_text,
                  "no pose on the field fits the points: none has %d points near a line, %.0f %% "
                  "of them near a line and a mean matching cost of at most %.2f m",
                  params.min_inliers, 100.0 * params.min_inlier_fraction, params.max_valid_cost_m);
    const std::string reason = reason_text;
    printResults(field, method, points.points.size(), guess.has_value(), results, reason,
                 &answers[best].rejected);
    if (results.empty()) {
      std::cerr << "fieldline-localize: " << reason << "\n";
      return 1;
    }
    if (!png.empty()) drawPng(field, points.points, results[0].pose, png);
    if (!results[0].valid) {
      std::cerr << "fieldline-localize: not valid: " << results[0].invalid_reason << "\n";
      return 1;
    }
    return 0;
  } catch (const std::invalid_argument& e) {
    std::cerr << "fieldline-localize: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "fieldline-localize: " << e.what() << "\n";
    return 2;
  }
}
