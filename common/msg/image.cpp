#include "common/msg/image.hpp"

#include <algorithm>
#include <stdexcept>

namespace fieldline::msg {

std::optional<camera::PixelFormat> pixelFormatOf(std::int8_t format) {
  switch (format) {
    case image_t::FORMAT_YUYV:
      return camera::PixelFormat::kYuyv;
    case image_t::FORMAT_BGR:
      return camera::PixelFormat::kBgr;
    default:
      return std::nullopt;
  }
}

std::int8_t formatCode(camera::PixelFormat format) {
  return format == camera::PixelFormat::kYuyv ? image_t::FORMAT_YUYV : image_t::FORMAT_BGR;
}

std::optional<camera::FrameView> fromMessage(const image_t& m) {
  return fromMessage(m, std::span<const std::uint8_t>(m.data));
}

std::optional<camera::FrameView> fromMessage(const image_t& m, std::span<const std::uint8_t> data) {
  const auto format = pixelFormatOf(m.format);
  if (!format) return std::nullopt;
  const camera::FrameView view{data.data(), m.width, m.height, m.stride, *format};
  if (!view.valid() ||
      data.size() < static_cast<std::size_t>(m.stride) * static_cast<std::size_t>(m.height)) {
    return std::nullopt;
  }
  return view;
}

void toMessage(const camera::FrameView& frame, image_t& m) {
  if (!frame.valid()) throw std::invalid_argument("toMessage: not a valid frame");
  const bool in_place =
      frame.data == m.data.data() && m.data.size() >= static_cast<std::size_t>(frame.stride) *
                                                          static_cast<std::size_t>(frame.height);
  if (in_place) {
    m.stride = frame.stride;
    m.data.resize(static_cast<std::size_t>(frame.stride) * static_cast<std::size_t>(frame.height));
  } else {
    // Only the pixels of each row are certain to exist in a foreign view: its last row may end
    // right after them.
    const int row_bytes = camera::FrameView::minStride(frame.width, frame.format);
    m.stride = row_bytes;
    m.data.resize(static_cast<std::size_t>(row_bytes) * static_cast<std::size_t>(frame.height));
    for (int v = 0; v < frame.height; ++v) {
      const std::uint8_t* row = frame.data + static_cast<std::ptrdiff_t>(v) * frame.stride;
      std::copy(row, row + row_bytes, m.data.begin() + static_cast<std::ptrdiff_t>(v) * row_bytes);
    }
  }
  m.width = frame.width;
  m.height = frame.height;
  m.format = formatCode(frame.format);
  m.size = static_cast<std::int32_t>(m.data.size());
}

}  // namespace fieldline::msg
