#include "common/device/device_check.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

namespace fieldline::device {
namespace {

const char* kListCameras = "list cameras with v4l2-ctl --list-devices (Debian package v4l-utils)";
const char* kListSerial =
    "is the controller plugged in and powered? list serial devices with ls -l /dev/serial/by-id/ "
    "(their names there do not change between boots)";

std::string kindOf(const struct stat& st) {
  if (S_ISREG(st.st_mode)) return "a regular file";
  if (S_ISDIR(st.st_mode)) return "a folder";
  if (S_ISBLK(st.st_mode)) return "a block device";
  if (S_ISSOCK(st.st_mode)) return "a socket";
  if (S_ISFIFO(st.st_mode)) return "a named pipe";
  if (S_ISCHR(st.st_mode)) return "a character device";
  return "not a device";
}

bool allDigits(const std::string& text) {
  return !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
}

// What VIDIOC_QUERYCAP says of an opened V4L2 node: "" for a video capture device.
std::string queryCamera(const std::string& path, int fd) {
  v4l2_capability caps{};
  if (::ioctl(fd, VIDIOC_QUERYCAP, &caps) != 0) {
    return fmt::format("{}: not a V4L2 device ({}); {}", path, std::strerror(errno), kListCameras);
  }
  const std::uint32_t device_caps =
      (caps.capabilities & V4L2_CAP_DEVICE_CAPS) != 0 ? caps.device_caps : caps.capabilities;
  if ((device_caps & (V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_VIDEO_CAPTURE_MPLANE)) == 0) {
    return fmt::format("{}: '{}' ({}) captures no video here (a camera's metadata node?); {}", path,
                       reinterpret_cast<const char*>(caps.card),
                       reinterpret_cast<const char*>(caps.driver), kListCameras);
  }
  return "";
}

}  // namespace

std::string cameraDevicePath(const std::string& path_or_index) {
  return allDigits(path_or_index) ? "/dev/video" + path_or_index : path_or_index;
}

std::string checkCamera(const std::string& path_or_index) {
  const std::string path = cameraDevicePath(path_or_index);
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return fmt::format("{}: no such device; {}", path, kListCameras);
    return fmt::format("{}: {}", path, std::strerror(errno));
  }
  if (!S_ISCHR(st.st_mode) && !S_ISFIFO(st.st_mode)) {
    return fmt::format(
        "{}: not a camera device ({}); a video file is --source video, a folder of images "
        "--source folder; {}",
        path, kindOf(st), kListCameras);
  }
  if (::access(path.c_str(), R_OK) != 0) {
    return fmt::format(
        "{}: permission denied; add the user to the video group (sudo adduser $USER video, "
        "then log in again)",
        path);
  }
  if (S_ISFIFO(st.st_mode)) return "";  // a stand-in camera: YUV4MPEG2 frames
  const int fd = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    return fmt::format("{}: cannot open: {}; {}", path, std::strerror(errno), kListCameras);
  }
  std::string problem = queryCamera(path, fd);
  ::close(fd);
  return problem;
}

std::string checkSerial(const std::string& path) {
  const bool under_dev = path.starts_with("/dev/");
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT && !under_dev) return "";  // a pseudo-terminal its creator makes later
    if (errno == ENOENT) return fmt::format("{}: no such device; {}", path, kListSerial);
    return fmt::format("{}: {}", path, std::strerror(errno));
  }
  if (!S_ISCHR(st.st_mode)) {
    return fmt::format("{}: not a serial device ({}); {}", path, kindOf(st), kListSerial);
  }
  if (::access(path.c_str(), R_OK | W_OK) != 0) {
    return fmt::format(
        "{}: permission denied; add the user to the dialout group (sudo adduser $USER "
        "dialout, then log in again)",
        path);
  }
  return "";
}

std::string checkInputFile(const std::string& path, const std::string& what, bool folder) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    return fmt::format("{}: no such {} ({})", path, what, std::strerror(errno));
  }
  if (folder != S_ISDIR(st.st_mode)) {
    return fmt::format("{}: {}, not the {} expected", path, kindOf(st), what);
  }
  if (::access(path.c_str(), R_OK | (folder ? X_OK : 0)) != 0) {
    return fmt::format("{}: cannot read the {}: permission denied", path, what);
  }
  return "";
}

int reportProblems(const std::string& process, const std::vector<std::string>& problems) {
  int code = 0;
  for (const std::string& p : problems) {
    if (p.empty()) continue;
    std::fprintf(stderr, "%s: %s\n", process.c_str(), p.c_str());
    code = 2;
  }
  return code;
}

}  // namespace fieldline::device
