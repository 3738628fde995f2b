// The line-point CSV reader of fieldline-localize.
#include "services/fusion/points_csv.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace fieldline::fusion {
namespace {

perception::LinePoints parse(const std::string& text, std::size_t max_points = 1000) {
  std::istringstream in(text);
  return readLinePointsCsv(in, "points.csv", max_points);
}

TEST(PointsCsv, ReadsPointsAndSequences) {
  const perception::LinePoints p =
      parse("# robot frame\n1.0,2.0\n 1.5 , -2.25\n\n\n3,4\r\n-0.5,0\n");
  ASSERT_EQ(p.points.size(), 4u);
  EXPECT_FLOAT_EQ(p.points[1].x, 1.5f);
  EXPECT_FLOAT_EQ(p.points[1].y, -2.25f);
  ASSERT_EQ(p.sequences.size(), 2u);
  EXPECT_EQ(p.sequences[0], std::make_pair(0, 2));
  EXPECT_EQ(p.sequences[1], std::make_pair(2, 4));
  EXPECT_TRUE(parse("").points.empty());
  EXPECT_TRUE(std::isnan(parse("nan,1\n").points[0].x));
}

TEST(PointsCsv, BadLinesNameFileAndLine) {
  for (const char* bad : {"1.0\n", "1,2,3\n", "a,b\n", "1,2x\n", "1e999,0\n", ",\n"}) {
    try {
      parse(std::string("0,0\n") + bad);
      ADD_FAILURE() << "accepted " << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("points.csv:2:"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(parse("0,0\n1,1\n2,2\n", 2), std::invalid_argument);
  EXPECT_THROW(readLinePointsCsvFile("/nonexistent/points.csv"), std::invalid_argument);
}

}  // namespace
}  // namespace fieldline::fusion
