// Real frame sources: cameras, video files and GStreamer pipelines through OpenCV's
// VideoCapture, and folders of still images. Each delivers frames as they come, in whatever size
// and layout (YUYV or BGR) the device gives: nothing converts a whole frame on the way, the
// vision reads pixels in place through FrameView.
//
// A source knows nothing of time stamps or buses: the camera node stamps each frame with its
// receive time minus the configured latency.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/camera/frame.hpp"

namespace fieldline::camera {

// One frame owned by the caller; reused from frame to frame, so a steady stream allocates
// nothing.
struct SourceFrame {
  std::vector<std::uint8_t> bytes;
  int width = 0;
  int height = 0;
  int stride = 0;
  PixelFormat format = PixelFormat::kBgr;
  // Counter of the source (0, 1, 2, ...): frames it delivered, not counting skipped ones.
  std::int64_t frame_number = 0;
  // Exposure time the source recorded with the frame, us since the epoch (LCM logs: the
  // logged header.utime); empty when the source does not know it (cameras, files).
  std::optional<std::int64_t> recorded_utime;

  FrameView view() const { return {bytes.data(), width, height, stride, format}; }
};

enum class SourceKind : std::uint8_t { kSim, kV4l2, kVideo, kGstreamer, kFolder, kLog };
// "sim", "v4l2", "video", "gstreamer", "folder", "log".
const char* sourceKindName(SourceKind kind);

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Blocks until the next frame and fills `out`; false once the source is exhausted (end of a
  // file or folder without looping) or broken (see lastError()). Unreadable frames are skipped
  // and counted in errors().
  virtual bool next(SourceFrame& out) = 0;
  virtual SourceKind kind() const = 0;
  // What was opened, for logs: "/dev/video0 640x480 YUYV".
  virtual std::string describe() const = 0;
  // Frames that could not be used (unreadable files, frames of an unknown layout).
  std::int64_t errors() const { return errors_; }
  const std::string& lastError() const { return last_error_; }

 protected:
  void countError(std::string text) {
    ++errors_;
    last_error_ = std::move(text);
  }
  // Why the source stopped delivering (not an unusable frame: nothing is counted).
  void noteProblem(std::string text) { last_error_ = std::move(text); }

 private:
  std::int64_t errors_ = 0;
  std::string last_error_;
};

struct VideoCaptureOptions {
  // v4l2: device path ("/dev/video0") or index ("0"); video: file path; gstreamer: a pipeline
  // ending in appsink.
  std::string spec;
  // Requested size and rate (v4l2 only; 0 = the device's default).
  int width = 0;
  int height = 0;
  double fps = 0.0;
  // v4l2: ask for raw YUYV instead of OpenCV's BGR conversion.
  bool raw_yuyv = true;
  // video: start again at the end.
  bool loop = false;
};

// Opens a camera (kV4l2), a video file (kVideo) or a GStreamer pipeline (kGstreamer); a named
// pipe given as camera or video is read as YUV4MPEG2 (sources_y4m.hpp). Throws
// std::runtime_error naming the spec if it cannot be opened.
std::unique_ptr<FrameSource> openVideoCapture(SourceKind kind, const VideoCaptureOptions& options);

// Whether `path` is a named pipe (FIFO).
bool isNamedPipe(const std::string& path);

// The PNG, JPEG and BMP files of a folder in name order, as BGR frames.
class ImageFolderSource final : public FrameSource {
 public:
  // Throws std::runtime_error if the folder does not exist or holds no such image.
  ImageFolderSource(const std::string& folder, bool loop);
  bool next(SourceFrame& out) override;
  SourceKind kind() const override { return SourceKind::kFolder; }
  std::string describe() const override;
  const std::vector<std::string>& files() const { return files_; }

 private:
  std::string folder_;
  bool loop_;
  std::vector<std::string> files_;
  std::size_t position_ = 0;
  std::int64_t delivered_ = 0;
};

}  // namespace fieldline::camera
