// Issue 34, red-team finding 10: exit codes and limits of the tools.
// - the camera exited 0 after publishing 0 frames from a corrupt video, and decoded a
//   decompression-bomb PNG in full (2.4 GB, 16 s) before refusing its size;
// - fieldline-features exited 0 on NaN input, said "expected two numbers" for 1e308 and read a
//   directory as --points as 0 points, silently;
// - fieldline-replay exited 0 on a file that is not a log (fixed by the recordings rework before
//   this: checked here so it stays so).
// (The INT64_MAX log stamp is redteam_future_overflow in redteam_bus_test.cpp.)
//
// Run against main at 6957b54 (before the fixes) the first three failed: the corrupt video ran
// without an exception (exit code 0), the 8000 x 8000 bomb was decoded and published as a frame
// without an error (5.9 s), and fieldline-features exited 0 for NaN, a directory and an empty
// file (and 2 with "expected two numbers" for 1e308). The replay case passed there already.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "common/bus/cli.hpp"
#include "services/camera/camera_app.hpp"

namespace fieldline {
namespace redteam_tools_test {

namespace fs = std::filesystem;

class redteam_exit_codes : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() / ("fieldline-redteam-tools-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    common.robot = 1;
    common.bus_url = "memq://";
  }
  void TearDown() override { fs::remove_all(dir); }

  // Runs a command; its exit code and what it printed (stdout and stderr).
  static int run(const std::string& command, std::string& output) {
    output.clear();
    FILE* p = ::popen((command + " 2>&1").c_str(), "r");
    if (!p) return -1;
    char buffer[4096];
    while (std::size_t n = std::fread(buffer, 1, sizeof buffer, p))
      output.append(buffer, n);
    const int status = ::pclose(p);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  std::string write(const std::string& name, const std::string& text) {
    const std::string path = (dir / name).string();
    std::ofstream(path) << text;
    return path;
  }
  static long maxRssKb() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return usage.ru_maxrss;
  }

  fs::path dir;
  bus::CommonOptions common;
  const std::string bin = FIELDLINE_BIN_DIR;
};

TEST_F(redteam_exit_codes, TheCameraFailsOnAVideoItCannotDecode) {
  const std::string path = (dir / "clip.avi").string();
  {
    cv::VideoWriter writer(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30.0,
                           cv::Size(96, 64));
    ASSERT_TRUE(writer.isOpened()) << "OpenCV cannot write MJPG/AVI here";
    for (int k = 0; k < 3; ++k)
      writer.write(cv::Mat(64, 96, CV_8UC3, cv::Scalar(40.0 * k, 80, 120)));
  }
  // Corrupt every JPEG frame from behind its start marker to its end marker (a decoder that
  // tolerates a damaged header still made frames of a partly damaged one); the AVI's structure
  // stays intact.
  std::vector<char> bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto marker = [&](std::size_t i, unsigned char second) {
    return static_cast<unsigned char>(bytes[i]) == 0xff &&
           static_cast<unsigned char>(bytes[i + 1]) == second;
  };
  int frames = 0;
  for (std::size_t i = 0; i + 1 < bytes.size(); ++i) {
    if (!marker(i, 0xd8)) continue;
    std::size_t k = i + 2;
    for (; k + 1 < bytes.size() && !marker(k, 0xd9); ++k)
      bytes[k] = static_cast<char>(0x5a);
    ++frames;
    i = k;
  }
  ASSERT_EQ(frames, 3);
  std::ofstream(path, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));

  camera::CameraAppOptions options;
  options.source = "video";
  options.input = path;
  options.fps = 200.0;
  try {
    camera::runCamera(options, common);
    FAIL() << "no error after publishing no frame (main: exit code 0)";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no frame published"), std::string::npos) << e.what();
  }
}

TEST_F(redteam_exit_codes, ADecompressionBombIsRefusedBeforeItIsDecoded) {
  fs::create_directories(dir / "frames");
  const std::string bomb = (dir / "frames" / "bomb.png").string();
  {
    // 8000 x 8000 pixels of black: 64 MB as grey, 192 MB decoded as colour, 70 kB as a PNG.
    const cv::Mat black(8000, 8000, CV_8UC1, cv::Scalar(0));
    ASSERT_TRUE(cv::imwrite(bomb, black, {cv::IMWRITE_PNG_COMPRESSION, 9}));
  }
  ASSERT_LT(fs::file_size(bomb), 1'000'000u);
  const long before_kb = maxRssKb();
  camera::CameraAppOptions options;
  options.source = "folder";
  options.input = (dir / "frames").string();
  options.fps = 200.0;
  try {
    camera::runCamera(options, common);
    FAIL() << "no error for a folder whose only image is refused";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("8000 x 8000"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not decoded"), std::string::npos) << e.what();
  }
  // Not decoded: the process did not grow by the 192 MB of the decoded image.
  EXPECT_LT(maxRssKb() - before_kb, 50'000) << "the bomb was decoded";
}

TEST_F(redteam_exit_codes, FeaturesRefusesInputThatIsNoLinePoints) {
  std::string out;
  const std::string features = bin + "/fieldline-features --points ";
  EXPECT_EQ(run(features + write("nan.csv", "1.0,2.0\nnan,1.0\n"), out), 2) << out;
  EXPECT_NE(out.find("nan.csv:2: x = nan is not a finite number"), std::string::npos) << out;
  EXPECT_EQ(run(features + write("big.csv", "1e308,1.0\n"), out), 2) << out;
  EXPECT_NE(out.find("big.csv:1: x = 1e308 is out of range: 1e+308 m"), std::string::npos) << out;
  EXPECT_EQ(run(features + dir.string(), out), 2) << out;
  EXPECT_NE(out.find("is a directory"), std::string::npos) << out;
  EXPECT_EQ(run(features + write("empty.csv", "# nothing\n"), out), 2) << out;
  EXPECT_NE(out.find("no line points"), std::string::npos) << out;
  // Good points still work.
  EXPECT_EQ(run(features + write("ok.csv", "1.0,0.0\n1.5,0.0\n2.0,0.0\n"), out), 0) << out;
}

TEST_F(redteam_exit_codes, ReplayFailsOnAFileThatIsNotALog) {
  std::string out;
  EXPECT_EQ(run(bin + "/fieldline-replay --robot 1 " + write("notes.txt", "not a log\n"), out), 1)
      << out;
  EXPECT_NE(out.find("damaged"), std::string::npos) << out;
}

}  // namespace redteam_tools_test
}  // namespace fieldline
