#include <cstdint>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus/channels.hpp"
#include "common/bus/checked_decode.hpp"

namespace fieldline::bus {
namespace checked_decode_test {

constexpr Utime kNow = 2'000'000;

// An encoded SERVICE_STATUS whose `process` string length (the int32 after the 8-byte
// fingerprint and the 33-byte header) is replaced by `length`, big-endian.
std::vector<std::uint8_t> statusWithProcessLength(std::int32_t length) {
  service_status_t m{};
  m.header.utime = 1'000'000;
  m.process = "fusion";
  std::vector<std::uint8_t> bytes(m.getEncodedSize());
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  const auto u = static_cast<std::uint32_t>(length);
  constexpr std::size_t kLengthOffset = 8 + 33;
  bytes[kLengthOffset] = static_cast<std::uint8_t>(u >> 24);
  bytes[kLengthOffset + 1] = static_cast<std::uint8_t>(u >> 16);
  bytes[kLengthOffset + 2] = static_cast<std::uint8_t>(u >> 8);
  bytes[kLengthOffset + 3] = static_cast<std::uint8_t>(u);
  return bytes;
}

std::optional<Rejection> check(const std::vector<std::uint8_t>& bytes) {
  return checkEncoded(channels::kServiceStatus.name, bytes.data(), static_cast<int>(bytes.size()),
                      kNow, 0);
}

TEST(CheckedDecode, WellFormedStringDecodes) {
  // "fusion" plus its NUL: the length the encoder wrote.
  const auto rejection = check(statusWithProcessLength(7));
  EXPECT_TRUE(!rejection || rejection->kind != "decode") << rejection->text;
}

// Found by tests/fuzz/fuzz_lcm_decode: a string length below 1 made `length - 1` overflow.
TEST(CheckedDecode, StringLengthBelowOneIsUndecodable) {
  for (std::int32_t length : {0, -1, std::numeric_limits<std::int32_t>::min()}) {
    const auto rejection = check(statusWithProcessLength(length));
    ASSERT_TRUE(rejection) << length;
    EXPECT_EQ(rejection->kind, "decode") << length;
  }
}

}  // namespace checked_decode_test
}  // namespace fieldline::bus
