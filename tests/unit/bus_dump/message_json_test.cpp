// The JSON writers of fieldline-bus-dump: the image summary, and refusal of bytes that do not
// decode (string escaping is tools/json's, tested in tests/unit/json).
#include <gtest/gtest.h>

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
