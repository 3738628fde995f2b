// fieldline-team-png: a picture of one robot's team picture. Listens to robot N's bus (and the
// simulator's, for the truth) until a TEAM_STATE shows at least --min-present robots, then draws
// it on the field: every present robot at its pose with its 2-sigma circle (the robot itself
// outlined in white), each robot's own ball (small, in its colour), the fused team ball (orange,
// with its 2-sigma ellipse) and, when SIM_WORLD is heard, the true robots and ball as grey
// rings. A legend line gives the ages and clock offsets.
//
//   fieldline-team-png --robot 1 --out docs/images/team_picture.png --min-present 6
#include <array>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <Eigen/Eigenvalues>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/bus/urls.hpp"
#include "common/field/field_model.hpp"
#include "common/msg/team_state.hpp"
#include "common/time/clock.hpp"

using namespace fieldline;

namespace {

const std::array<cv::Scalar, 6> kRobotColours{{{255, 120, 40},
                                               {60, 60, 230},
                                               {230, 60, 230},
                                               {40, 200, 230},
                                               {240, 200, 60},
                                               {120, 255, 120}}};

class Canvas {
 public:
  Canvas(const field::FieldModel& field, double px_per_m) : scale_(px_per_m) {
    half_ = field.carpetHalfExtent();
    image_ = cv::Mat(static_cast<int>(std::ceil(2 * half_.y() * scale_)) + kLegend,
                     static_cast<int>(std::ceil(2 * half_.x() * scale_)), CV_8UC3,
                     cv::Scalar(40, 120, 40));
    const int line = std::max(1, static_cast<int>(std::lround(field.lineWidth() * scale_)));
    for (const field::LineSegment& s : field.segments())
      cv::line(image_, px(s.a), px(s.b), cv::Scalar(255, 255, 255), line, cv::LINE_AA);
    for (const field::LineArc& a : field.arcs()) {
      const int n = 64;
      for (int i = 0; i < n; ++i) {
        const double t0 = a.start_angle + a.sweep * i / n;
        const double t1 = a.start_angle + a.sweep * (i + 1) / n;
        cv::line(image_, px(a.centre + a.radius * field::Vec2(std::cos(t0), std::sin(t0))),
                 px(a.centre + a.radius * field::Vec2(std::cos(t1), std::sin(t1))),
                 cv::Scalar(255, 255, 255), line, cv::LINE_AA);
      }
    }
    cv::rectangle(image_, {0, image_.rows - kLegend}, {image_.cols, image_.rows},
                  cv::Scalar(30, 30, 30), cv::FILLED);
  }

  cv::Point px(const field::Vec2& p) const {
    return {static_cast<int>(std::lround((p.x() + half_.x()) * scale_)),
            static_cast<int>(std::lround((half_.y() - p.y()) * scale_))};
  }
  int len(double metres) const {
    return std::max(1, static_cast<int>(std::lround(metres * scale_)));
  }

  void robot(double x, double y, double phi, double sigma, const cv::Scalar& colour, bool self,
             int id) {
    const cv::Point c = px({x, y});
    cv::circle(image_, c, len(2.0 * sigma + 0.26), colour, 1, cv::LINE_AA);
    cv::circle(image_, c, len(0.25), colour, cv::FILLED, cv::LINE_AA);
    if (self) cv::circle(image_, c, len(0.25), cv::Scalar(255, 255, 255), 2, cv::LINE_AA);
    cv::line(image_, c, px({x + 0.4 * std::cos(phi), y + 0.4 * std::sin(phi)}), cv::Scalar(0, 0, 0),
             2, cv::LINE_AA);
    cv::putText(image_, std::to_string(id), c + cv::Point(len(0.3), -len(0.3)),
                cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  }
  void ring(double x, double y, double r, const cv::Scalar& colour) {
    cv::circle(image_, px({x, y}), len(r), colour, 1, cv::LINE_AA);
  }
  void dot(double x, double y, double r, const cv::Scalar& colour) {
    cv::circle(image_, px({x, y}), len(r), colour, cv::FILLED, cv::LINE_AA);
  }
  void ellipse(double x, double y, const Eigen::Matrix2d& cov, const cv::Scalar& colour) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(cov);
    if (es.info() != Eigen::Success) return;
    const Eigen::Vector2d ev = es.eigenvalues().cwiseMax(1e-8);
    const Eigen::Vector2d axis = es.eigenvectors().col(1);
    const double angle = -std::atan2(axis.y(), axis.x()) * 180.0 / M_PI;
    cv::ellipse(image_, px({x, y}),
                cv::Size(len(2.0 * std::sqrt(ev(1))) + 2, len(2.0 * std::sqrt(ev(0))) + 2), angle,
                0, 360, colour, 1, cv::LINE_AA);
  }
  void legend(int row, const std::string& text) {
    cv::putText(image_, text, {8, image_.rows - kLegend + 18 + 18 * row}, cv::FONT_HERSHEY_SIMPLEX,
                0.45, cv::Scalar(230, 230, 230), 1, cv::LINE_AA);
  }
  const cv::Mat& image() const { return image_; }

  static constexpr int kLegend = 64;

 private:
  double scale_;
  field::Vec2 half_;
  cv::Mat image_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Draws robot N's TEAM_STATE (its team picture) on the field into a PNG, with the "
      "simulator's truth as grey rings when SIM_WORLD is heard."};
  int robot = 1;
  std::string out = "team_picture.png";
  std::string field_name = "msl";
  int min_present = 6;
  double timeout_s = 60.0;
  double px_per_m = 40.0;
  app.add_option("--robot", robot, "Robot whose TEAM_STATE to draw")->check(CLI::Range(1, 6));
  app.add_option("--out", out, "PNG to write")->capture_default_str();
  app.add_option("--field", field_name, "Field preset")->capture_default_str();
  app.add_option("--min-present", min_present, "Wait for this many present robots")
      ->check(CLI::Range(1, 6))
      ->capture_default_str();
  app.add_option("--timeout", timeout_s, "Give up after this many seconds")
      ->check(CLI::Range(1.0, 3600.0))
      ->capture_default_str();
  app.add_option("--px-per-m", px_per_m, "Scale")->check(CLI::Range(5.0, 200.0));
  FIELDLINE_PARSE(app, argc, argv);

  return bus::runMain("team_png", [&]() -> int {
    const field::FieldModel field = field::loadFieldPreset(field_name);
    SystemClock clock;
    bus::Node node({.process = "team_png",
                    .robot_id = 0,
                    .url = bus::robotBusUrl(robot),
                    .status_period_us = 0},
                   clock);
    const bus::BusId sim = node.addBus(bus::simBusUrl());
    std::optional<world_state_t> world;
    std::optional<perception::TeamState> picked;
    node.subscribe(
        bus::channels::kSimWorld, [&](const world_state_t& w) { world = w; }, sim);
    node.subscribe(bus::channels::kTeamState, [&](const team_state_t& m) {
      if (picked) return;
      const perception::TeamState s = msg::fromMessage(m);
      int present = 0;
      for (const auto& r : s.robots)
        present += r.present ? 1 : 0;
      if (present >= min_present && s.team_ball_valid) picked = s;
    });
    bus::installStopSignals();
    const Utime start = clock.monotonicNow();
    while (!picked && !bus::stopSignalReceived() &&
           clock.monotonicNow() - start < static_cast<Utime>(timeout_s * 1e6)) {
      node.spinOnce(100);
    }
    if (!picked) {
      std::fprintf(stderr, "no TEAM_STATE with %d robots present and a team ball on robot %d\n",
                   min_present, robot);
      return 1;
    }
    Canvas canvas(field, px_per_m);
    if (world) {
      for (int i = 0; i < world->num_robots; ++i)
        canvas.ring(world->robot_x[i], world->robot_y[i], 0.32, cv::Scalar(160, 160, 160));
      for (int i = 0; i < world->num_opponents; ++i)
        canvas.dot(world->opponent_x[i], world->opponent_y[i], world->opponent_radius[i],
                   cv::Scalar(20, 20, 20));
      canvas.ring(world->ball_x, world->ball_y, 0.2, cv::Scalar(160, 160, 160));
    }
    std::string ages = "age ms:", offsets = "offset ms:";
    for (int i = 0; i < perception::kTeamSize; ++i) {
      const perception::TeammateState& r = picked->robots[static_cast<std::size_t>(i)];
      if (!r.present) {
        ages += fmt::format("  r{} -", i + 1);
        continue;
      }
      const cv::Scalar colour = kRobotColours[static_cast<std::size_t>(i)];
      canvas.robot(r.x, r.y, r.phi, r.sigma_xy, colour, i + 1 == robot, i + 1);
      if (r.ball_valid) canvas.dot(r.ball_x, r.ball_y, 0.07, colour);
      ages += fmt::format("  r{} {:.0f}", i + 1, static_cast<double>(r.robot_age_us) * 1e-3);
      offsets += fmt::format("  r{} {:+.1f}", i + 1, static_cast<double>(r.clock_offset_us) * 1e-3);
    }
    canvas.dot(picked->team_ball_x, picked->team_ball_y, 0.11, cv::Scalar(0, 140, 255));
    canvas.ellipse(picked->team_ball_x, picked->team_ball_y, picked->team_ball_covariance,
                   cv::Scalar(0, 140, 255));
    canvas.legend(
        0, fmt::format("TEAM_STATE of robot {} (white ring); team ball orange; truth grey", robot) +
               "   " + ages);
    canvas.legend(1, offsets);
    if (!cv::imwrite(out, canvas.image())) throw std::runtime_error("cannot write " + out);
    std::printf("%s\n", out.c_str());
    return 0;
  });
}
