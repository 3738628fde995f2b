#include "common/camera/image_header.hpp"

#include <algorithm>
#include <array>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <vector>

namespace fieldline::camera {
namespace {

std::uint32_t bigEndian(const std::uint8_t* p, int bytes) {
  std::uint32_t v = 0;
  for (int i = 0; i < bytes; ++i)
    v = (v << 8) | p[i];
  return v;
}

std::int32_t littleEndian32(const std::uint8_t* p) {
  return static_cast<std::int32_t>(
      static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
      (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24));
}

[[noreturn]] void malformed(const std::string& path, const std::string& what) {
  throw std::runtime_error(path + ": " + what);
}

bool readExactly(std::ifstream& in, std::uint8_t* out, std::size_t n) {
  in.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n));
  return static_cast<std::size_t>(in.gcount()) == n;
}

// JPEG: markers until a start-of-frame, whose segment holds the height and width.
ImageHeaderSize jpegSize(std::ifstream& in, const std::string& path) {
  in.seekg(2);
  for (int segments = 0; segments < 10000; ++segments) {
    std::uint8_t marker[2];
    if (!readExactly(in, marker, 2)) malformed(path, "JPEG ends before its frame header");
    if (marker[0] != 0xff) malformed(path, "JPEG marker expected");
    if (marker[1] == 0xff) {  // fill byte
      in.seekg(-1, std::ios::cur);
      continue;
    }
    // Markers without a length.
    if (marker[1] == 0x01 || (marker[1] >= 0xd0 && marker[1] <= 0xd7)) continue;
    if (marker[1] == 0xd9 || marker[1] == 0xda) {
      malformed(path, "JPEG without a frame header before its image data");
    }
    std::uint8_t length_bytes[2];
    if (!readExactly(in, length_bytes, 2)) malformed(path, "JPEG segment cut off");
    const std::uint32_t length = bigEndian(length_bytes, 2);
    if (length < 2) malformed(path, "JPEG segment of length < 2");
    const bool start_of_frame = marker[1] >= 0xc0 && marker[1] <= 0xcf && marker[1] != 0xc4 &&
                                marker[1] != 0xc8 && marker[1] != 0xcc;
    if (start_of_frame) {
      std::uint8_t sof[5];
      if (length < 7 || !readExactly(in, sof, 5)) malformed(path, "JPEG frame header cut off");
      return {static_cast<int>(bigEndian(sof + 3, 2)), static_cast<int>(bigEndian(sof + 1, 2))};
    }
    in.seekg(static_cast<std::streamoff>(length - 2), std::ios::cur);
  }
  malformed(path, "JPEG without a frame header");
}

}  // namespace

std::optional<ImageHeaderSize> readImageHeaderSize(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::array<std::uint8_t, 26> head{};
  in.read(reinterpret_cast<char*>(head.data()), head.size());
  const auto got = static_cast<std::size_t>(in.gcount());
  in.clear();
  static constexpr std::array<std::uint8_t, 8> kPng{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (got >= 8 && std::equal(kPng.begin(), kPng.end(), head.begin())) {
    // Signature, then the IHDR chunk first: length, "IHDR", width, height (big-endian).
    if (got < 24 || head[12] != 'I' || head[13] != 'H' || head[14] != 'D' || head[15] != 'R') {
      malformed(path, "PNG without its IHDR header");
    }
    const std::uint32_t w = bigEndian(head.data() + 16, 4);
    const std::uint32_t h = bigEndian(head.data() + 20, 4);
    if (w > 0x7fffffffu || h > 0x7fffffffu) malformed(path, "PNG size beyond 2^31");
    return ImageHeaderSize{static_cast<int>(w), static_cast<int>(h)};
  }
  if (got >= 2 && head[0] == 0xff && head[1] == 0xd8) return jpegSize(in, path);
  if (got >= 2 && head[0] == 'B' && head[1] == 'M') {
    if (got < 26) malformed(path, "BMP header cut off");
    const std::int32_t w = littleEndian32(head.data() + 18);
    const std::int32_t h = littleEndian32(head.data() + 22);  // negative: stored top-down
    if (w < 0 || h == std::numeric_limits<std::int32_t>::min()) malformed(path, "BMP size invalid");
    return ImageHeaderSize{w, h < 0 ? -h : h};
  }
  return std::nullopt;
}

std::optional<ImageHeaderSize> checkImageSize(const std::string& path) {
  const auto size = readImageHeaderSize(path);
  if (!size) return size;
  const std::int64_t pixels = static_cast<std::int64_t>(size->width) * size->height;
  if (size->width <= 0 || size->height <= 0) {
    throw std::runtime_error(path + ": the header declares an empty image (" +
                             std::to_string(size->width) + " x " + std::to_string(size->height) +
                             ")");
  }
  if (size->width > kMaxImageSide || size->height > kMaxImageSide || pixels > kMaxImagePixels) {
    throw std::runtime_error(path + ": the header declares " + std::to_string(size->width) + " x " +
                             std::to_string(size->height) +
                             " pixels, more than any camera frame (at most " +
                             std::to_string(kMaxImageSide) + " a side and " +
                             std::to_string(kMaxImagePixels) + " pixels); not decoded");
  }
  return size;
}

}  // namespace fieldline::camera
