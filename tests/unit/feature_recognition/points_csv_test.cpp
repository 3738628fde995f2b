#include "services/feature_recognition/points_csv.hpp"

#include <sstream>
#include <stdexcept>

#include <gtest/gtest.h>

namespace fieldline::feature_recognition {
namespace {

TEST(PointsCsv, ReadsSequencesSeparatedByBlankLinesAndRoundTrips) {
  std::istringstream in("# comment\n1,2\n3, 4\n\n\n5 6\r\n-0.5,1e-1\n");
  const auto points = readPointsCsv(in);
  ASSERT_EQ(points.points.size(), 4u);
  EXPECT_EQ(points.sequences, (std::vector<std::pair<int, int>>{{0, 2}, {2, 4}}));
  EXPECT_FLOAT_EQ(points.points[1].y, 4.0f);
  EXPECT_FLOAT_EQ(points.points[3].x, -0.5f);
  EXPECT_FLOAT_EQ(points.points[3].y, 0.1f);
  std::ostringstream out;
  writePointsCsv(out, points);
  std::istringstream again(out.str());
  const auto copy = readPointsCsv(again);
  EXPECT_EQ(copy.sequences, points.sequences);
  EXPECT_FLOAT_EQ(copy.points[2].x, 5.0f);
}

TEST(PointsCsv, NamesTheBadLine) {
  std::istringstream in("1,2\n3,x\n");
  try {
    readPointsCsv(in, "frame.csv");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("frame.csv:2"), std::string::npos);
  }
  std::istringstream trailing("1,2,3\n");
  EXPECT_THROW(readPointsCsv(trailing), std::runtime_error);
}

}  // namespace
}  // namespace fieldline::feature_recognition
