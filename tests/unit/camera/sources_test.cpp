#include "services/camera/sources.hpp"

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

namespace fieldline::camera {
namespace sources_test {

namespace fs = std::filesystem;

// A fresh folder under the build's temp dir, removed at the end of the test.
class TempFolder {
 public:
  explicit TempFolder(const std::string& name)
      : path_(fs::temp_directory_path() / ("fieldline_camera_" + name)) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempFolder() { fs::remove_all(path_); }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::string str() const { return path_.string(); }

 private:
  fs::path path_;
};

cv::Mat patternImage(int width, int height, int seed) {
  cv::Mat image(height, width, CV_8UC3);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      image.at<cv::Vec3b>(v, u) = {static_cast<uchar>((u * 7 + seed) % 256),
                                   static_cast<uchar>((v * 5 + seed) % 256),
                                   static_cast<uchar>(seed * 40 % 256)};
    }
  }
  return image;
}

TEST(ImageFolderSource, DeliversImagesInNameOrderAsBgrOfAnySize) {
  TempFolder dir("folder_order");
  ASSERT_TRUE(cv::imwrite(dir.file("b.png"), patternImage(64, 48, 2)));
  ASSERT_TRUE(cv::imwrite(dir.file("a.bmp"), patternImage(30, 20, 1)));
  ASSERT_TRUE(cv::imwrite(dir.file("c.PNG"), patternImage(33, 17, 3)));
  std::ofstream(dir.file("notes.txt")) << "not an image";
  std::ofstream(dir.file("broken.png")) << "not a png either";

  ImageFolderSource source(dir.str(), false);
  EXPECT_EQ(source.files().size(), 4u);  // a.bmp, b.png, broken.png, c.PNG
  SourceFrame frame;
  ASSERT_TRUE(source.next(frame));
  EXPECT_EQ(frame.width, 30);
  EXPECT_EQ(frame.height, 20);
  EXPECT_EQ(frame.format, PixelFormat::kBgr);
  EXPECT_EQ(frame.stride, 90);
  EXPECT_EQ(frame.frame_number, 0);
  // Pixel (5, 3) of the seed-1 pattern: B = 36, G = 16, R = 40.
  const Bgr px = readBgr(frame.view(), 5, 3);
  EXPECT_EQ(px.b, 36);
  EXPECT_EQ(px.g, 16);
  EXPECT_EQ(px.r, 40);
  ASSERT_TRUE(source.next(frame));
  EXPECT_EQ(frame.width, 64);
  // broken.png is skipped and counted.
  ASSERT_TRUE(source.next(frame));
  EXPECT_EQ(frame.width, 33);
  EXPECT_EQ(frame.height, 17);
  EXPECT_EQ(frame.frame_number, 2);
  EXPECT_EQ(source.errors(), 1);
  EXPECT_NE(source.lastError().find("broken.png"), std::string::npos);
  EXPECT_FALSE(source.next(frame));
}

TEST(ImageFolderSource, LoopsWhenAsked) {
  TempFolder dir("folder_loop");
  ASSERT_TRUE(cv::imwrite(dir.file("only.png"), patternImage(8, 8, 4)));
  ImageFolderSource source(dir.str(), true);
  SourceFrame frame;
  for (int k = 0; k < 5; ++k)
    ASSERT_TRUE(source.next(frame));
  EXPECT_EQ(frame.frame_number, 4);
}

TEST(ImageFolderSource, MissingOrEmptyFolderIsAnError) {
  EXPECT_THROW(ImageFolderSource("/nonexistent/fieldline", false), std::runtime_error);
  TempFolder dir("folder_empty");
  EXPECT_THROW(ImageFolderSource(dir.str(), false), std::runtime_error);
}

TEST(VideoCaptureSource, ReadsAVideoFileAsBgrAndLoops) {
  TempFolder dir("video");
  const std::string path = dir.file("clip.avi");
  {
    cv::VideoWriter writer(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30.0,
                           cv::Size(96, 64));
    ASSERT_TRUE(writer.isOpened()) << "OpenCV cannot write MJPG/AVI here";
    for (int k = 0; k < 3; ++k)
      writer.write(patternImage(96, 64, k + 1));
  }
  VideoCaptureOptions options;
  options.spec = path;
  options.loop = true;
  const std::unique_ptr<FrameSource> source = openVideoCapture(SourceKind::kVideo, options);
  SourceFrame frame;
  for (int k = 0; k < 7; ++k) {
    ASSERT_TRUE(source->next(frame)) << "frame " << k;
    EXPECT_EQ(frame.width, 96);
    EXPECT_EQ(frame.height, 64);
    EXPECT_EQ(frame.format, PixelFormat::kBgr);
  }
  EXPECT_EQ(frame.frame_number, 6);
  // The red channel of frame k is 40 (k + 1), within JPEG loss; frame 6 is the first again.
  EXPECT_NEAR(readBgr(frame.view(), 40, 30).r, 40, 8);
}

TEST(VideoCaptureSource, UnopenableSpecNamesIt) {
  VideoCaptureOptions options;
  options.spec = "/nonexistent/clip.avi";
  try {
    (void)openVideoCapture(SourceKind::kVideo, options);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/clip.avi"), std::string::npos);
  }
}

}  // namespace sources_test
}  // namespace fieldline::camera
