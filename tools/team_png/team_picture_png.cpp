#include "tools/team_png/team_picture_png.hpp"

#include <cmath>
#include <string>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

namespace fieldline::team_png {

namespace {}  // namespace

const std::array<cv::Scalar, 6> kRobotColours{{{255, 120, 40},
                                               {60, 60, 230},
                                               {230, 60, 230},
                                               {40, 200, 230},
                                               {240, 200, 60},
                                               {120, 255, 120}}};

namespace {

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

  static constexpr int kLegend = kLegendRows;

 private:
  double scale_;
  field::Vec2 half_;
  cv::Mat image_;
};

}  // namespace

cv::Point fieldPixel(const field::FieldModel& field, double px_per_m, const field::Vec2& p) {
  const field::Vec2 half = field.carpetHalfExtent();
  return {static_cast<int>(std::lround((p.x() + half.x()) * px_per_m)),
          static_cast<int>(std::lround((half.y() - p.y()) * px_per_m))};
}

cv::Mat drawTeamPicture(const field::FieldModel& field, const perception::TeamState& picture,
                        int self, const perception::WorldTruth* truth, double px_per_m) {
  Canvas canvas(field, px_per_m);
  if (truth) {
    for (const perception::TrueRobot& r : truth->robots)
      canvas.ring(r.pose.x, r.pose.y, 0.32, cv::Scalar(160, 160, 160));
    for (const perception::TrueOpponent& o : truth->opponents)
      canvas.dot(o.pose.x, o.pose.y, o.radius, cv::Scalar(20, 20, 20));
    canvas.ring(truth->ball.position.x(), truth->ball.position.y(), 0.2, cv::Scalar(160, 160, 160));
  }
  std::string ages = "age ms:", offsets = "offset ms:";
  for (int i = 0; i < perception::kTeamSize; ++i) {
    const perception::TeammateState& r = picture.robots[static_cast<std::size_t>(i)];
    if (!r.present) {
      ages += fmt::format("  r{} -", i + 1);
      continue;
    }
    const cv::Scalar colour = kRobotColours[static_cast<std::size_t>(i)];
    canvas.robot(r.x, r.y, r.phi, r.sigma_xy, colour, i + 1 == self, i + 1);
    if (r.ball_valid) canvas.dot(r.ball_x, r.ball_y, 0.07, colour);
    ages += fmt::format("  r{} {:.0f}", i + 1, static_cast<double>(r.robot_age_us) * 1e-3);
    offsets += fmt::format("  r{} {:+.1f}", i + 1, static_cast<double>(r.clock_offset_us) * 1e-3);
  }
  if (picture.team_ball_valid) {
    canvas.dot(picture.team_ball_x, picture.team_ball_y, 0.11, kTeamBallColour);
    canvas.ellipse(picture.team_ball_x, picture.team_ball_y, picture.team_ball_covariance,
                   kTeamBallColour);
  }
  canvas.legend(
      0, fmt::format("TEAM_STATE of robot {} (white ring); team ball orange; truth grey", self) +
             "   " + ages);
  canvas.legend(1, offsets);
  return canvas.image();
}

}  // namespace fieldline::team_png
