// The line-points CSV reader and writer (fieldline-localize, fieldline-features, the evaluation
// tools' dumps).
#include "common/perception/line_points_csv.hpp"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace fieldline::perception {
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
}

TEST(PointsCsv, SpacesAloneSeparateXAndYAndWhatIsWrittenReadsBack) {
  const perception::LinePoints p = parse("# comment\n1,2\n3, 4\n\n\n5 6\r\n-0.5,1e-1\n");
  ASSERT_EQ(p.points.size(), 4u);
  EXPECT_EQ(p.sequences, (std::vector<std::pair<int, int>>{{0, 2}, {2, 4}}));
  EXPECT_FLOAT_EQ(p.points[1].y, 4.0f);
  EXPECT_FLOAT_EQ(p.points[2].x, 5.0f);
  EXPECT_FLOAT_EQ(p.points[3].y, 0.1f);
  std::ostringstream out;
  writeLinePointsCsv(out, p);
  const perception::LinePoints copy = parse(out.str());
  EXPECT_EQ(copy.sequences, p.sequences);
  ASSERT_EQ(copy.points.size(), p.points.size());
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    EXPECT_FLOAT_EQ(copy.points[i].x, p.points[i].x);
    EXPECT_FLOAT_EQ(copy.points[i].y, p.points[i].y);
  }
}

TEST(PointsCsv, MillimetresScaleToMetres) {
  std::istringstream in("1500,-250\n");
  const perception::LinePoints p = readLinePointsCsv(in, "mm.csv", 10, 0.001);
  ASSERT_EQ(p.points.size(), 1u);
  EXPECT_FLOAT_EQ(p.points[0].x, 1.5f);
  EXPECT_FLOAT_EQ(p.points[0].y, -0.25f);
}

TEST(PointsCsv, NonFiniteAndAbsurdCoordinatesAreRefusedWithTheValue) {
  const std::pair<const char*, const char*> cases[] = {
      {"nan,1\n", "points.csv:2: x = nan is not a finite number"},
      {"1,inf\n", "points.csv:2: y = inf is not a finite number"},
      {"1e999,0\n", "points.csv:2: x = 1e999 is not a finite number"},
      {"1e308,0\n", "points.csv:2: x = 1e308 is "},
      {"0,-200\n", "more than 100 m: wrong units?"},
  };
  for (const auto& [line, message] : cases) {
    try {
      parse(std::string("0,0\n") + line);
      ADD_FAILURE() << "accepted " << line;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  }
}

TEST(PointsCsv, ADirectoryOrAnEmptyFileIsAnError) {
  const auto expectError = [](const std::string& path, const std::string& message) {
    try {
      readLinePointsCsvFile(path);
      ADD_FAILURE() << "accepted " << path;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  };
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("points_csv_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  expectError(dir.string(), "is a directory");
  const std::string empty = (dir / "empty.csv").string();
  { std::ofstream(empty) << "# nothing\n\n"; }
  expectError(empty, "no line points");
  expectError("/dev/null", "not a regular file");
  std::filesystem::remove_all(dir);
}

TEST(PointsCsv, BadLinesNameFileAndLine) {
  for (const char* bad :
       {"1.0\n", "1,2,3\n", "a,b\n", "1,2x\n", "1e999,0\n", ",\n", "1,,2\n", "1 2 3\n"}) {
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
}  // namespace fieldline::perception
