// YUV4MPEG2 on a named pipe (services/camera/sources_y4m.hpp): the header, the planes <-> YUYV
// conversions, and a writer and a reader on a real pipe: frames arrive unchanged, a reader that is
// not there or falls behind makes the writer drop frames (never block), a silent or closed pipe
// ends next() with the reason, and a reader that comes back gets a fresh header.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

#include "services/camera/sources.hpp"
#include "services/camera/sources_y4m.hpp"

namespace fieldline::camera {
namespace y4m_test {

std::string errorOf(const std::string& header) {
  try {
    parseY4mHeader(header);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

std::vector<std::uint8_t> testYuyv(int width, int height, int seed) {
  std::vector<std::uint8_t> yuyv(static_cast<std::size_t>(width) * height * 2);
  for (std::size_t i = 0; i < yuyv.size(); ++i)
    yuyv[i] = static_cast<std::uint8_t>((i * 7 + static_cast<std::size_t>(seed) * 13) % 251);
  return yuyv;
}

TEST(Y4mHeader, ReadsSizeRateAndColourSpace) {
  const Y4mFormat f = parseY4mHeader("YUV4MPEG2 W640 H480 F30000:1001 Ip A1:1 C422");
  EXPECT_EQ(f.width, 640);
  EXPECT_EQ(f.height, 480);
  EXPECT_NEAR(f.fps, 29.97, 0.01);
  EXPECT_EQ(f.chroma, Y4mFormat::Chroma::k422);
  EXPECT_EQ(f.frameBytes(), 640u * 480u * 2u);
  // No C tag: 4:2:0, as the format says.
  EXPECT_EQ(parseY4mHeader("YUV4MPEG2 W6 H3").chroma, Y4mFormat::Chroma::k420);
  EXPECT_EQ(parseY4mHeader("YUV4MPEG2 W6 H3").frameBytes(), 18u + 2u * 3u * 2u);
  EXPECT_EQ(parseY4mHeader("YUV4MPEG2 W6 H3 Cmono").frameBytes(), 18u);
  // What the writer writes, the reader reads.
  const std::string written = y4mHeader(320, 240, 30.0);
  EXPECT_EQ(written, "YUV4MPEG2 W320 H240 F30000:1000 Ip A1:1 C422\n");
  EXPECT_NEAR(parseY4mHeader(written.substr(0, written.size() - 1)).fps, 30.0, 1e-9);
}

TEST(Y4mHeader, RefusesWhatItCannotRead) {
  EXPECT_NE(errorOf("P6 640 480").find("not a YUV4MPEG2 stream"), std::string::npos);
  EXPECT_NE(errorOf("YUV4MPEG2 W640").find("without W and H"), std::string::npos);
  EXPECT_NE(errorOf("YUV4MPEG2 W641 H480").find("width 641 is odd"), std::string::npos);
  EXPECT_NE(errorOf("YUV4MPEG2 W640 H480 C444").find("C444 is not read"), std::string::npos);
  EXPECT_NE(errorOf("YUV4MPEG2 Wx H480").find("bad width 'x'"), std::string::npos);
}

TEST(Y4mPlanes, YuyvRoundTripsThrough422Planes) {
  const int w = 8, h = 4;
  const std::vector<std::uint8_t> yuyv = testYuyv(w, h, 1);
  std::vector<std::uint8_t> planes(static_cast<std::size_t>(w) * h * 2);
  yuyvToY4mPlanes(yuyv.data(), w, h, w * 2, planes.data());
  // Y plane first: pixel (1, 0) is byte 2 of YUYV.
  EXPECT_EQ(planes[1], yuyv[2]);
  std::vector<std::uint8_t> back(yuyv.size());
  Y4mFormat f;
  f.width = w;
  f.height = h;
  f.chroma = Y4mFormat::Chroma::k422;
  y4mPlanesToYuyv(f, planes.data(), back.data());
  EXPECT_EQ(back, yuyv);
}

TEST(Y4mPlanes, FourTwoZeroUsesEachChromaRowTwiceAndMonoIsGrey) {
  const int w = 4, h = 2;
  // Y: 1..8, U: 50 60, V: 70 80 (one chroma row for both image rows).
  const std::vector<std::uint8_t> planes{1, 2, 3, 4, 5, 6, 7, 8, 50, 60, 70, 80};
  Y4mFormat f;
  f.width = w;
  f.height = h;
  f.chroma = Y4mFormat::Chroma::k420;
  std::vector<std::uint8_t> yuyv(16);
  y4mPlanesToYuyv(f, planes.data(), yuyv.data());
  EXPECT_EQ(yuyv,
            (std::vector<std::uint8_t>{1, 50, 2, 70, 3, 60, 4, 80, 5, 50, 6, 70, 7, 60, 8, 80}));
  f.chroma = Y4mFormat::Chroma::kMono;
  y4mPlanesToYuyv(f, planes.data(), yuyv.data());
  EXPECT_EQ(yuyv[1], 128);
  EXPECT_EQ(yuyv[8], 5);
}

class Y4mPipe : public ::testing::Test {
 protected:
  void SetUp() override {
    scratch_dir =
        std::filesystem::temp_directory_path() / ("y4m_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(scratch_dir);
    pipe_path = (scratch_dir / "camera.fifo").string();
  }
  void TearDown() override { std::filesystem::remove_all(scratch_dir); }
  std::filesystem::path scratch_dir;
  std::string pipe_path;
};

TEST_F(Y4mPipe, FramesArriveUnchangedAndTheReaderSeesThemAsACameraWould) {
  const int w = 16, h = 8;
  Y4mPipeWriter writer(pipe_path, w, h, 30.0);  // makes the pipe
  EXPECT_TRUE(isNamedPipe(pipe_path));
  // Nobody reads yet: dropped, not blocked.
  const std::vector<std::uint8_t> first = testYuyv(w, h, 1);
  EXPECT_EQ(writer.write(first.data(), w * 2), Y4mPipeWriter::Result::kNoReader);

  Y4mPipeSource source(pipe_path, 2.0);
  EXPECT_EQ(source.kind(), SourceKind::kVideo);
  SourceFrame frame;
  for (int k = 0; k < 3; ++k) {
    const std::vector<std::uint8_t> sent = testYuyv(w, h, k + 2);
    ASSERT_EQ(writer.write(sent.data(), w * 2), Y4mPipeWriter::Result::kWritten);
    ASSERT_TRUE(source.next(frame)) << source.lastError();
    EXPECT_EQ(frame.width, w);
    EXPECT_EQ(frame.height, h);
    EXPECT_EQ(frame.format, PixelFormat::kYuyv);
    EXPECT_EQ(frame.frame_number, k);
    EXPECT_FALSE(frame.recorded_utime.has_value());  // stamped on receipt, like a camera's
    EXPECT_EQ(frame.bytes, sent);
  }
  EXPECT_NE(source.describe().find("16x8 4:2:2"), std::string::npos) << source.describe();
}

TEST_F(Y4mPipe, ASilentPipeAndAClosedOneEndTheStreamWithTheReason) {
  ASSERT_EQ(::mkfifo(pipe_path.c_str(), 0600), 0);
  {
    // No writer ever: next() gives up after its timeout, it does not take the pipe for ended.
    Y4mPipeSource source(pipe_path, 0.2);
    SourceFrame frame;
    EXPECT_FALSE(source.next(frame));
    EXPECT_NE(source.lastError().find("no frame for 0.2 s"), std::string::npos)
        << source.lastError();
  }
  Y4mPipeSource source(pipe_path, 2.0);
  {
    Y4mPipeWriter writer(pipe_path, 4, 2, 30.0);
    const std::vector<std::uint8_t> sent = testYuyv(4, 2, 3);
    ASSERT_EQ(writer.write(sent.data(), 8), Y4mPipeWriter::Result::kWritten);
  }
  SourceFrame frame;
  EXPECT_TRUE(source.next(frame));
  EXPECT_FALSE(source.next(frame));
  EXPECT_NE(source.lastError().find("the writer closed the pipe"), std::string::npos)
      << source.lastError();
}

TEST_F(Y4mPipe, AReaderThatFallsBehindLosesFramesAndOneThatReturnsGetsAHeader) {
  const int w = 64, h = 48;  // 6 kB frames: many fit the pipe
  Y4mPipeWriter writer(pipe_path, w, h, 30.0);
  auto reader = std::make_unique<Y4mPipeSource>(pipe_path, 2.0);
  const std::vector<std::uint8_t> sent = testYuyv(w, h, 5);
  int written = 0, dropped = 0;
  for (int k = 0; k < 400; ++k) {
    const auto r = writer.write(sent.data(), w * 2);
    written += r == Y4mPipeWriter::Result::kWritten;
    dropped += r == Y4mPipeWriter::Result::kReaderBehind;
  }
  EXPECT_GT(written, 0);
  EXPECT_GT(dropped, 0) << "a reader that never reads must make the writer drop frames";
  SourceFrame frame;
  ASSERT_TRUE(reader->next(frame)) << reader->lastError();
  // The reader goes away with frames unread and a new one comes: it starts at a header.
  reader.reset();
  EXPECT_EQ(writer.write(sent.data(), w * 2), Y4mPipeWriter::Result::kNoReader);
  reader = std::make_unique<Y4mPipeSource>(pipe_path, 2.0);
  ASSERT_EQ(writer.write(sent.data(), w * 2), Y4mPipeWriter::Result::kWritten);
  ASSERT_TRUE(reader->next(frame)) << reader->lastError();
  EXPECT_EQ(frame.bytes, sent);
  EXPECT_EQ(frame.frame_number, 0);
}

TEST_F(Y4mPipe, AFileThatIsNoPipeIsRefused) {
  std::ofstream(pipe_path) << "x";
  EXPECT_THROW(Y4mPipeWriter(pipe_path, 4, 2, 30.0), std::runtime_error);
}

}  // namespace y4m_test
}  // namespace fieldline::camera
