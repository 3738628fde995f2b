// image_t <-> camera::FrameView (common/msg/image.hpp): views of YUYV and BGR messages, refusal of
// other formats and of sizes that do not describe the data, in-place and copying conversion.
#include "common/msg/image.hpp"

#include <vector>

#include <gtest/gtest.h>

namespace fieldline::msg {
namespace image_msg_test {

image_t yuyvImage(int width, int height, int stride) {
  image_t m{};
  m.header.utime = 1;
  m.width = width;
  m.height = height;
  m.stride = stride;
  m.format = image_t::FORMAT_YUYV;
  m.size = stride * height;
  m.data.resize(static_cast<std::size_t>(m.size));
  for (std::size_t i = 0; i < m.data.size(); ++i)
    m.data[i] = static_cast<std::uint8_t>(i);
  return m;
}

TEST(ImageMsg, ViewsYuyvAndBgrMessagesInPlace) {
  const image_t m = yuyvImage(4, 3, 10);
  const auto view = fromMessage(m);
  ASSERT_TRUE(view);
  EXPECT_EQ(view->data, m.data.data());
  EXPECT_EQ(view->width, 4);
  EXPECT_EQ(view->height, 3);
  EXPECT_EQ(view->stride, 10);
  EXPECT_EQ(view->format, camera::PixelFormat::kYuyv);

  image_t bgr = m;
  bgr.format = image_t::FORMAT_BGR;
  bgr.width = 3;
  ASSERT_TRUE(fromMessage(bgr));
  EXPECT_EQ(fromMessage(bgr)->format, camera::PixelFormat::kBgr);
}

TEST(ImageMsg, RefusesOtherFormatsAndSizesThatDoNotFitTheData) {
  image_t grey = yuyvImage(4, 3, 10);
  grey.format = image_t::FORMAT_GRAY;
  EXPECT_FALSE(fromMessage(grey));
  EXPECT_FALSE(pixelFormatOf(42));

  image_t short_data = yuyvImage(4, 3, 10);
  short_data.data.resize(25);
  EXPECT_FALSE(fromMessage(short_data));

  image_t narrow_stride = yuyvImage(4, 3, 10);
  narrow_stride.stride = 7;  // less than 4 YUYV pixels
  EXPECT_FALSE(fromMessage(narrow_stride));

  image_t odd_yuyv = yuyvImage(4, 3, 10);
  odd_yuyv.width = 3;
  EXPECT_FALSE(fromMessage(odd_yuyv));
}

TEST(ImageMsg, ToMessageKeepsASwappedInBufferAndCopiesForeignFramesCompactly) {
  // A buffer swapped into the message: only the layout is written, nothing copied.
  image_t m{};
  std::vector<std::uint8_t> pixels(30, 7);
  m.data.swap(pixels);
  const std::uint8_t* before = m.data.data();
  toMessage(camera::FrameView{m.data.data(), 4, 3, 10, camera::PixelFormat::kYuyv}, m);
  EXPECT_EQ(m.data.data(), before);
  EXPECT_EQ(m.stride, 10);
  EXPECT_EQ(m.size, 30);
  EXPECT_EQ(m.format, image_t::FORMAT_YUYV);

  // A foreign BGR frame with padded rows: rows copied without the padding.
  std::vector<std::uint8_t> foreign(2 * 16);
  for (std::size_t i = 0; i < foreign.size(); ++i)
    foreign[i] = static_cast<std::uint8_t>(i);
  image_t out{};
  toMessage(camera::FrameView{foreign.data(), 3, 2, 16, camera::PixelFormat::kBgr}, out);
  EXPECT_EQ(out.stride, 9);
  EXPECT_EQ(out.size, 18);
  EXPECT_EQ(out.format, image_t::FORMAT_BGR);
  EXPECT_EQ(out.data[8], 8);
  EXPECT_EQ(out.data[9], 16);  // second row starts at the foreign stride
  const auto back = fromMessage(out);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->width, 3);

  EXPECT_THROW(toMessage(camera::FrameView{}, out), std::invalid_argument);
}

}  // namespace image_msg_test
}  // namespace fieldline::msg
