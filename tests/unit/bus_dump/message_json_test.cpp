// The JSON writers of fieldline-bus-dump: the image summary, and refusal of bytes that do not
// decode (string escaping is tools/json's, tested in tests/unit/json).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "common/bus/channels.hpp"
#include "tools/bus_dump/message_json.hpp"

using namespace fieldline;

namespace {

template <typename Msg>
std::vector<std::uint8_t> encode(const Msg& msg) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(msg.getEncodedSize()));
  msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

}  // namespace

TEST(Fnv1a64, MatchesTheReferenceValues) {
  EXPECT_EQ(bus_dump::fnv1a64(nullptr, 0), 0xcbf29ce484222325ULL);
  const std::uint8_t a[] = {'a'};
  EXPECT_EQ(bus_dump::fnv1a64(a, 1), 0xaf63dc4c8601ec8cULL);
}

TEST(MessageJson, ImageDataIsSummarisedUnlessAskedFor) {
  image_t image{};
  image.header.utime = 1;
  image.width = 2;
  image.height = 1;
  image.stride = 2;
  image.format = image_t::FORMAT_GRAY;
  image.size = 2;
  image.data = {7, 255};
  const auto bytes = encode(image);
  std::string summary;
  ASSERT_TRUE(bus_dump::appendMessageJson(summary, bus::channels::kCameraImage.name, bytes.data(),
                                          static_cast<int>(bytes.size()), {}));
  EXPECT_NE(summary.find("\"data_fnv1a64\":\""), std::string::npos) << summary;
  EXPECT_EQ(summary.find("\"data\":"), std::string::npos) << summary;
  std::string full;
  ASSERT_TRUE(bus_dump::appendMessageJson(full, bus::channels::kCameraImage.name, bytes.data(),
                                          static_cast<int>(bytes.size()), {.image_data = true}));
  EXPECT_NE(full.find("\"data\":[7,255]"), std::string::npos) << full;
}

TEST(MessageJson, NonFiniteNumbersBecomeNull) {
  odometry_t odometry{};
  odometry.dx = std::numeric_limits<double>::quiet_NaN();
  odometry.dy = std::numeric_limits<double>::infinity();
  const auto bytes = encode(odometry);
  std::string out;
  ASSERT_TRUE(bus_dump::appendMessageJson(out, bus::channels::kOdometry.name, bytes.data(),
                                          static_cast<int>(bytes.size()), {}));
  EXPECT_NE(out.find("\"dx\":null,\"dy\":null"), std::string::npos) << out;
}

TEST(MessageJson, RefusesBytesThatDoNotDecodeAndUnknownChannels) {
  const std::uint8_t garbage[] = {1, 2, 3};
  std::string out;
  EXPECT_FALSE(bus_dump::appendMessageJson(out, bus::channels::kOdometry.name, garbage, 3, {}));
  odometry_t odometry{};
  const auto bytes = encode(odometry);
  EXPECT_FALSE(bus_dump::appendMessageJson(out, bus::channels::kRobotState.name, bytes.data(),
                                           static_cast<int>(bytes.size()), {}));
  EXPECT_FALSE(bus_dump::appendMessageJson(out, "NOT_A_CHANNEL", bytes.data(),
                                           static_cast<int>(bytes.size()), {}));
}

TEST(MessageJson, EveryFieldIsWrittenAsTheTypesSayIncludingTheNewestOnes) {
  // The writers are generated from lcmtypes/: fields the hand-kept ones forgot are in.
  service_status_t status{};
  status.process = "fusion";
  status.state_reason = "ODOMETRY silent 2.1 s";
  status.header.publisher_id = 1234;
  const auto bytes = encode(status);
  std::string out;
  ASSERT_TRUE(bus_dump::appendMessageJson(out, bus::channels::kServiceStatus.name, bytes.data(),
                                          static_cast<int>(bytes.size()), {}));
  EXPECT_NE(out.find("\"state_reason\":\"ODOMETRY silent 2.1 s\""), std::string::npos) << out;
  EXPECT_NE(out.find("\"publisher_id\":1234"), std::string::npos) << out;
}

TEST(MessageCsv, AHeaderLineAndOneRowPerMessage) {
  robot_state_t state{};
  state.header.utime = 1'700'000'000'000'123;
  state.header.seq = 5;
  state.x = 1.5;
  state.covariance[8] = 0.25;
  state.status = robot_state_t::STATUS_TRACKING;
  state.twin_ambiguous = 1;
  const auto bytes = encode(state);
  std::string header;
  ASSERT_TRUE(bus_dump::appendCsvHeader(header, bus::channels::kRobotState.name));
  EXPECT_EQ(header.rfind("log_utime,header.utime,header.utime_published,header.seq,", 0), 0u)
      << header;
  EXPECT_NE(header.find(",covariance[0],"), std::string::npos);
  EXPECT_NE(header.find(",covariance[8],status,since_vision_us,twin_ambiguous"), std::string::npos);
  std::string row;
  ASSERT_TRUE(bus_dump::appendCsvRow(row, bus::channels::kRobotState.name, 42, bytes.data(),
                                     static_cast<int>(bytes.size()), {}));
  EXPECT_EQ(row.rfind("42,1700000000000123,0,5,", 0), 0u) << row;
  EXPECT_EQ(row.substr(row.size() - 11), ",0.25,2,0,1") << row;
  // As many cells as columns.
  EXPECT_EQ(std::count(row.begin(), row.end(), ','), std::count(header.begin(), header.end(), ','));
  // A variable-length array is one quoted cell holding a JSON array.
  line_contours_t lines{};
  lines.num_points = 2;
  lines.u = lines.v = lines.x = lines.y = {1.5f, 2.0f};
  const auto line_bytes = encode(lines);
  std::string line_row;
  ASSERT_TRUE(bus_dump::appendCsvRow(line_row, bus::channels::kVisionLines.name, 1,
                                     line_bytes.data(), static_cast<int>(line_bytes.size()), {}));
  EXPECT_NE(line_row.find(",\"[1.5,2]\","), std::string::npos) << line_row;
  EXPECT_FALSE(bus_dump::appendCsvHeader(header, "NOT_A_CHANNEL"));
}
