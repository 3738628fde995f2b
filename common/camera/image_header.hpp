// The size of a PNG, JPEG or BMP image read from its header, before anything decodes it: a
// decompression bomb (a small PNG of 20000 x 40000 pixels) is refused without the gigabytes and
// seconds a decoder spends on it (issue 34, red-team finding 10: the camera decoded 2.4 GB in
// 16 s before refusing the size). Plain file reading, no OpenCV.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace fieldline::camera {

struct ImageHeaderSize {
  int width = 0;
  int height = 0;
};

// Largest image the project decodes: 8192 px a side and 16.7 Mpx (48 MB as BGR), far above any
// robot camera (640 x 480 to 2048 x 2048).
inline constexpr int kMaxImageSide = 8192;
inline constexpr std::int64_t kMaxImagePixels = 4096LL * 4096LL;

// The width and height the file's header declares; nothing for a format it does not know (the
// decoder then decides). Throws std::runtime_error for a file that cannot be read or whose header
// is cut off or malformed.
std::optional<ImageHeaderSize> readImageHeaderSize(const std::string& path);

// Throws std::runtime_error naming the file and its size when the header declares an image larger
// than kMaxImageSide or kMaxImagePixels (or an empty one); returns the size when known.
std::optional<ImageHeaderSize> checkImageSize(const std::string& path);

}  // namespace fieldline::camera
