// The device checks behind --check-args and fieldline-launch --dry-run: every problem names the
// path, what is wrong and the fix; what can be used passes.
#include <gtest/gtest.h>

#include <grp.h>
#include <pty.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "common/device/device_check.hpp"

namespace fieldline::device {
namespace {

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

class DeviceCheck : public ::testing::Test {
 protected:
  void SetUp() override {
    scratch_dir = std::filesystem::temp_directory_path() /
                  ("device_check_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(scratch_dir);
    plain_file = (scratch_dir / "frame.png").string();
    std::ofstream(plain_file) << "not a device";
    fifo_path = (scratch_dir / "camera.fifo").string();
    ASSERT_EQ(::mkfifo(fifo_path.c_str(), 0600), 0);
  }
  void TearDown() override { std::filesystem::remove_all(scratch_dir); }

  std::filesystem::path scratch_dir;
  std::string plain_file;
  std::string fifo_path;
};

TEST_F(DeviceCheck, AMissingCameraIsNamedWithHowToListCameras) {
  const std::string p = checkCamera("/dev/nosuch-video");
  EXPECT_EQ(p,
            "/dev/nosuch-video: no such device; list cameras with v4l2-ctl --list-devices (Debian "
            "package v4l-utils)");
  // An index is /dev/videoN.
  EXPECT_EQ(cameraDevicePath("7"), "/dev/video7");
  EXPECT_EQ(cameraDevicePath("/dev/video7"), "/dev/video7");
  if (!std::filesystem::exists("/dev/video97")) {
    EXPECT_TRUE(contains(checkCamera("97"), "/dev/video97: no such device")) << checkCamera("97");
  }
}

TEST_F(DeviceCheck, ACameraMustBeAV4l2CaptureDeviceOrAPipe) {
  EXPECT_TRUE(contains(checkCamera(plain_file),
                       "not a camera device (a regular file); a video file "
                       "is --source video"))
      << checkCamera(plain_file);
  // A character device that is no V4L2 device.
  EXPECT_TRUE(contains(checkCamera("/dev/null"), "/dev/null: not a V4L2 device"))
      << checkCamera("/dev/null");
  // A named pipe stands in for a camera (the rehearsal's renderer writes into it).
  EXPECT_EQ(checkCamera(fifo_path), "");
}

TEST_F(DeviceCheck, AMissingSerialDeviceIsNamedWithHowToFindIt) {
  const std::string p = checkSerial("/dev/nosuch");
  EXPECT_TRUE(contains(p,
                       "/dev/nosuch: no such device; is the controller plugged in and "
                       "powered? list serial devices with ls -l /dev/serial/by-id/"))
      << p;
  EXPECT_TRUE(contains(checkSerial(plain_file), "not a serial device (a regular file)"))
      << checkSerial(plain_file);
  EXPECT_TRUE(contains(checkSerial(fifo_path), "not a serial device (a named pipe)"));
}

TEST_F(DeviceCheck, APseudoTerminalPasses) {
  int controller = -1;
  int terminal = -1;
  char name[256] = {};
  ASSERT_EQ(::openpty(&controller, &terminal, name, nullptr, nullptr), 0);
  EXPECT_EQ(checkSerial(name), "") << name;
  // The simulator's link to it (outside /dev) is checked like the device when it exists...
  const std::string link = (scratch_dir / "robot1.tty").string();
  std::filesystem::create_symlink(name, link);
  EXPECT_EQ(checkSerial(link), "");
  ::close(terminal);
  ::close(controller);
  // ... and is no problem before the simulator made it.
  EXPECT_EQ(checkSerial((scratch_dir / "robot2.tty").string()), "");
}

// `check` run as an unprivileged user: root may open anything, so as root (CI) the check runs in
// a child that has dropped to nobody (65534) and sends back what it found.
std::string asUnprivilegedUser(const std::function<std::string()>& check) {
  if (::geteuid() != 0) return check();
  int fds[2];
  if (::pipe(fds) != 0) return "pipe failed";
  const pid_t child = ::fork();
  if (child == 0) {
    ::close(fds[0]);
    const std::string result =
        ::setgroups(0, nullptr) == 0 && ::setgid(65534) == 0 && ::setuid(65534) == 0
            ? check()
            : std::string("could not drop to nobody");
    const ssize_t written = ::write(fds[1], result.data(), result.size());
    ::_exit(written == static_cast<ssize_t>(result.size()) ? 0 : 1);
  }
  ::close(fds[1]);
  std::string result;
  char buffer[512];
  for (ssize_t n; (n = ::read(fds[0], buffer, sizeof buffer)) > 0;)
    result.append(buffer, static_cast<std::size_t>(n));
  ::close(fds[0]);
  ::waitpid(child, nullptr, 0);
  return result;
}

TEST_F(DeviceCheck, PermissionProblemsNameTheGroup) {
  ::chmod(fifo_path.c_str(), 0);
  const std::string problem = asUnprivilegedUser([&] { return checkCamera(fifo_path); });
  EXPECT_TRUE(contains(problem, "permission denied; add the user to the video group")) << problem;
}

TEST_F(DeviceCheck, InputFilesAndFolders) {
  EXPECT_EQ(checkInputFile(plain_file, "video file", false), "");
  EXPECT_EQ(checkInputFile(scratch_dir.string(), "image folder", true), "");
  EXPECT_TRUE(contains(checkInputFile(scratch_dir.string(), "video file", false),
                       "a folder, not the video file expected"));
  EXPECT_TRUE(contains(checkInputFile(plain_file, "image folder", true),
                       "a regular file, not the image folder expected"));
  EXPECT_TRUE(contains(checkInputFile((scratch_dir / "none.avi").string(), "video file", false),
                       "none.avi: no such video file"));
}

TEST(DeviceReport, PrintsEachProblemAndFailsWithCodeTwo) {
  EXPECT_EQ(reportProblems("camera", {"", ""}), 0);
  EXPECT_EQ(reportProblems("camera", {"", "/dev/video0: no such device"}), 2);
}

}  // namespace
}  // namespace fieldline::device
