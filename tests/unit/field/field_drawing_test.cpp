// Every field preset drawn (tools/field_png) agrees with its model: the pixels on every line centre
// are painted, the carpet away from lines, goals and marks is not, and the painted area is the
// lines' length times their width.
#include "tools/field_png/field_drawing.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/config/config.hpp"

namespace fieldline::field_png {
namespace field_drawing_test {

using field::FieldModel;
using field::Vec2;

std::vector<std::string> allPresets() {
  std::vector<std::string> names;
  for (const auto& entry :
       std::filesystem::directory_iterator(config::projectRoot() + "/config/field")) {
    if (entry.path().extension() == ".yaml") names.push_back(entry.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

constexpr double kPxPerM = 50.0;

bool isColour(const cv::Mat& image, const cv::Point& px, const cv::Scalar& colour) {
  if (px.x < 0 || px.y < 0 || px.x >= image.cols || px.y >= image.rows) return false;
  const cv::Vec3b c = image.at<cv::Vec3b>(px);
  return c[0] == colour[0] && c[1] == colour[1] && c[2] == colour[2];
}

// How much of a pixel is line paint: its blue channel between the carpet's and the line's.
double whiteness(const cv::Mat& image, const cv::Point& px) {
  if (px.x < 0 || px.y < 0 || px.x >= image.cols || px.y >= image.rows) return 0.0;
  const double b = image.at<cv::Vec3b>(px)[0];
  return std::clamp((b - kCarpet[0]) / (kLine[0] - kCarpet[0]), 0.0, 1.0);
}

cv::Point pixelOf(const FieldModel& m, const Vec2& p) {
  const cv::Point2d q = fieldToPixel(m, kPxPerM, p);
  return {static_cast<int>(std::lround(q.x)), static_cast<int>(std::lround(q.y))};
}

class DrawnPreset : public ::testing::TestWithParam<std::string> {};

TEST_P(DrawnPreset, LinesArePaintedWhereTheModelHasThem) {
  const FieldModel m = field::loadFieldPreset(GetParam());
  const cv::Mat image = drawField(m, kPxPerM);
  ASSERT_FALSE(image.empty());
  const Vec2 carpet = m.carpetHalfExtent();
  EXPECT_NEAR(image.cols, 2 * (carpet.x() + kBarrierThickness) * kPxPerM, 1.0);
  EXPECT_NEAR(image.rows, 2 * (carpet.y() + kBarrierThickness) * kPxPerM, 1.0);

  int on_line = 0, painted = 0;
  for (const Vec2& p : m.sampleLines(0.02)) {
    ++on_line;
    painted += whiteness(image, pixelOf(m, p)) >= 0.9 ? 1 : 0;
  }
  EXPECT_EQ(painted, on_line) << "line centres not painted white";

  // Carpet points clear of every line, of the goals and the marks: the square ends of the painted
  // strips reach half a width times sqrt(2) from a line's end, the anti-aliased edge 2-3 px.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> x(-carpet.x(), carpet.x());
  std::uniform_real_distribution<double> y(-carpet.y(), carpet.y());
  const double clear =
      std::max(m.lineWidth(), m.boundaryLineWidth()) / std::sqrt(2.0) + 3.0 / kPxPerM;
  int carpet_points = 0, carpet_green = 0;
  for (int k = 0; k < 4000; ++k) {
    const Vec2 p(x(rng), y(rng));
    if (m.distance(p) < clear) continue;
    // The carpet's edge against the barrier is blended.
    if (std::abs(p.x()) > carpet.x() - 2.0 / kPxPerM ||
        std::abs(p.y()) > carpet.y() - 2.0 / kPxPerM) {
      continue;
    }
    if (std::abs(p.x()) > m.length() / 2 && std::abs(p.y()) < m.goals()[0].width / 2 + clear) {
      continue;  // a goal
    }
    bool near_mark = false;
    for (const Vec2& mark : m.penaltyMarks())
      near_mark = near_mark || (p - mark).norm() < m.dimensions().penalty_mark_diameter / 2 + clear;
    if (near_mark) continue;
    ++carpet_points;
    const bool green = isColour(image, pixelOf(m, p), kCarpet);
    carpet_green += green ? 1 : 0;
    if (!green) {
      const cv::Vec3b c = image.at<cv::Vec3b>(pixelOf(m, p));
      ADD_FAILURE() << "not carpet at " << p.transpose() << " (" << m.distance(p)
                    << " m from a line): " << int(c[0]) << " " << int(c[1]) << " " << int(c[2]);
    }
  }
  EXPECT_GT(carpet_points, 1000);
  EXPECT_EQ(carpet_green, carpet_points) << "carpet painted where the model has no line";

  // The painted area (each pixel by its share of paint, inside the lines' outer edges where the
  // goals are not) is the lines' length times their width, plus the marks; overlaps at junctions
  // and the segments' extended ends move it a little, and OpenCV's anti-aliased fill paints up to
  // half a pixel beyond each edge.
  double expected = 0.0, length = 0.0;
  for (const auto& s : m.segments()) {
    expected += s.length() * s.width;
    length += s.length();
  }
  for (const auto& a : m.arcs()) {
    expected += a.radius * a.sweep * a.width;
    length += a.radius * a.sweep;
  }
  for (std::size_t i = 0; i < m.penaltyMarks().size(); ++i) {
    const double r = m.dimensions().penalty_mark_diameter / 2;
    expected += std::acos(-1.0) * r * r;
  }
  const cv::Point low = pixelOf(m, Vec2(-m.length() / 2 - m.boundaryLineWidth() / 2,
                                        m.width() / 2 + m.boundaryLineWidth() / 2));
  const cv::Point high = pixelOf(m, Vec2(m.length() / 2 + m.boundaryLineWidth() / 2,
                                         -m.width() / 2 - m.boundaryLineWidth() / 2));
  double white = 0.0;
  for (int row = low.y; row <= high.y; ++row) {
    for (int col = low.x; col <= high.x; ++col)
      white += whiteness(image, {col, row});
  }
  const double white_m2 = white / (kPxPerM * kPxPerM);
  EXPECT_GT(white_m2, 0.9 * expected);
  EXPECT_LT(white_m2, 1.05 * (expected + length / kPxPerM));
  std::printf("%s: %zu segments, %zu arcs, painted %.3f m2 (model %.3f m2)\n", GetParam().c_str(),
              m.segments().size(), m.arcs().size(), white_m2, expected);
}

INSTANTIATE_TEST_SUITE_P(Field, DrawnPreset, ::testing::ValuesIn(allPresets()));

}  // namespace field_drawing_test
}  // namespace fieldline::field_png
