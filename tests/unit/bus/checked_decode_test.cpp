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

// ImageView (region tracking's CAMERA_IMAGE without a copy of the pixels) reads what image_t's
// decoder reads: the same fields and pixels, and for every damaged message the same rejection,
// kind and text.
TEST(CheckedDecode, AnImageViewIsWhatTheDecoderReads) {
  std::uint32_t random = 12345;
  const auto next = [&] {
    random = random * 1664525u + 1013904223u;
    return random >> 8;
  };
  const auto image = [&](int width, int height, std::int8_t format, int bytes_per_pixel) {
    image_t m{};
    m.header.utime = 1'000'000 + next();
    m.header.utime_published = m.header.utime + 60'000;
    m.header.seq = next();
    m.header.robot_id = 3;
    m.header.publisher_id = static_cast<std::int64_t>(next()) << 20;
    m.width = width;
    m.height = height;
    m.stride = width * bytes_per_pixel + static_cast<int>(next() % 3);
    m.format = format;
    m.source = image_t::SOURCE_SIM;
    m.frame_number = next();
    m.exposure_us = static_cast<std::int32_t>(next() % 1000);
    m.size = m.stride * m.height;
    m.data.resize(static_cast<std::size_t>(m.size));
    for (auto& b : m.data)
      b = static_cast<std::uint8_t>(next());
    return m;
  };
  std::vector<std::vector<std::uint8_t>> cases;
  for (const image_t& m :
       {image(320, 240, image_t::FORMAT_YUYV, 2), image(64, 48, image_t::FORMAT_BGR, 3),
        image(2, 1, image_t::FORMAT_GRAY, 1), image(7, 5, image_t::FORMAT_YUYV, 2)}) {
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
    ASSERT_EQ(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
              static_cast<int>(bytes.size()));
    cases.push_back(bytes);
    // Damaged: cut short, a byte more, each of the first 80 bytes (fingerprint, header, fields)
    // changed, a foreign type.
    cases.emplace_back(bytes.begin(), bytes.end() - 1);
    cases.emplace_back(bytes.begin(), bytes.begin() + 30);
    auto longer = bytes;
    longer.push_back(0);
    cases.push_back(longer);
    for (std::size_t i = 0; i < 80 && i < bytes.size(); ++i) {
      auto changed = bytes;
      changed[i] = static_cast<std::uint8_t>(changed[i] ^ (1u << (next() % 8)));
      cases.push_back(changed);
      changed[i] = 0xff;
      cases.push_back(changed);
    }
  }
  odometry_t odo{};
  std::vector<std::uint8_t> foreign(static_cast<std::size_t>(odo.getEncodedSize()));
  odo.encode(foreign.data(), 0, static_cast<int>(foreign.size()));
  cases.push_back(foreign);
  cases.emplace_back();

  ImageView view;
  image_t decoded;
  int accepted = 0;
  for (const auto& bytes : cases) {
    const auto expected = decodeChecked(decoded, bytes.data(), static_cast<int>(bytes.size()));
    const auto got = decodeCheckedView(view, bytes.data(), static_cast<int>(bytes.size()));
    ASSERT_EQ(expected.has_value(), got.has_value());
    if (expected) {
      EXPECT_EQ(got->kind, expected->kind);
      EXPECT_EQ(got->text, expected->text);
      continue;
    }
    ++accepted;
    image_t fields = view.fields;
    fields.data.assign(view.data.begin(), view.data.end());
    std::vector<std::uint8_t> again(static_cast<std::size_t>(fields.getEncodedSize()));
    fields.encode(again.data(), 0, static_cast<int>(again.size()));
    std::vector<std::uint8_t> reference(static_cast<std::size_t>(decoded.getEncodedSize()));
    decoded.encode(reference.data(), 0, static_cast<int>(reference.size()));
    EXPECT_EQ(again, reference);
    // The pixels are read where they are.
    EXPECT_EQ(view.data.data(), bytes.data() + bytes.size() - view.data.size());
  }
  // The intact four, and damaged ones that still read (a changed stamp, a changed pixel).
  EXPECT_GE(accepted, 4);
  EXPECT_LT(accepted, static_cast<int>(cases.size()) - 100);
}

}  // namespace checked_decode_test
}  // namespace fieldline::bus
