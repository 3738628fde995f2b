// YUV4MPEG2 on a named pipe: a stand-in for a camera device. A real robot's launch file names its
// camera's V4L2 device; given a named pipe (FIFO) in its place, the camera reads YUV4MPEG2 frames
// from it instead and stamps them as it stamps a camera's (receive time - latency). The rehearsal
// (docs/launch.md) feeds it with frames the simulator renders; `ffmpeg -i clip.mp4 -pix_fmt
// yuv422p -f yuv4mpegpipe PIPE` feeds it with a recording.
//
// Format (the YUV4MPEG2 of mjpegtools/ffmpeg): a header line "YUV4MPEG2 W640 H480 F30:1 Ip A1:1
// C422", then per frame "FRAME" (optional parameters) "\n" and the planes Y, U, V. Colour spaces
// read: 422, 420 (420jpeg, 420paldv, 420mpeg2) and mono; frames come out as YUYV (4:2:0 chroma
// rows are used twice, mono is grey). The writer writes C422 from YUYV.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "services/camera/sources.hpp"

namespace fieldline::camera {

struct Y4mFormat {
  int width = 0;
  int height = 0;
  // Frame rate as the header gives it (0 when absent), Hz.
  double fps = 0.0;
  enum class Chroma : std::uint8_t { k420, k422, kMono } chroma = Chroma::k420;
  // Bytes of one frame's planes.
  std::size_t frameBytes() const;
};

// Parses a header line (without its newline). Throws std::runtime_error naming what is wrong: not
// YUV4MPEG2, no or bad size, an odd width (YUYV pairs pixels), a colour space it cannot read.
Y4mFormat parseY4mHeader(const std::string& line);
// The header line (with its newline) of a C422 stream.
std::string y4mHeader(int width, int height, double fps);

// Planes of a Y4M frame -> YUYV rows of `format.width * 2` bytes.
void y4mPlanesToYuyv(const Y4mFormat& format, const std::uint8_t* planes, std::uint8_t* yuyv);
// YUYV rows (`stride` bytes apart) -> 4:2:2 planes Y, U, V.
void yuyvToY4mPlanes(const std::uint8_t* yuyv, int width, int height, int stride,
                     std::uint8_t* planes);

// Reads a YUV4MPEG2 stream from a named pipe. Opening does not wait for a writer; next() waits up
// to `frame_timeout_s` for each frame and returns false (lastError() says why) when none came,
// when the writer closed the pipe, or when the stream is broken, so the camera reports the loss
// and reopens (as it does with an unplugged camera).
class Y4mPipeSource final : public FrameSource {
 public:
  // Throws std::runtime_error if `path` cannot be opened.
  explicit Y4mPipeSource(std::string path, double frame_timeout_s = 2.0);
  ~Y4mPipeSource() override;
  Y4mPipeSource(const Y4mPipeSource&) = delete;
  Y4mPipeSource& operator=(const Y4mPipeSource&) = delete;

  bool next(SourceFrame& out) override;
  SourceKind kind() const override { return SourceKind::kVideo; }
  std::string describe() const override;
  const Y4mFormat& format() const { return format_; }

 private:
  // Waits for and appends bytes to buffer_; false on end of stream or timeout (error recorded).
  bool fill(std::int64_t deadline_ms);
  bool readLine(std::string& line, std::int64_t deadline_ms);
  bool readBytes(std::uint8_t* out, std::size_t n, std::int64_t deadline_ms);

  std::string path_;
  double frame_timeout_s_;
  int fd_ = -1;
  bool have_header_ = false;
  Y4mFormat format_;
  std::vector<std::uint8_t> buffer_;
  std::size_t buffer_start_ = 0;
  std::vector<std::uint8_t> planes_;
  std::int64_t delivered_ = 0;
};

// Writes frames into a named pipe as YUV4MPEG2 C422, as a camera delivers them, never blocking:
// what does not fit the pipe is kept and sent first at the next frame, and while it does not fit
// new frames are dropped (a camera drops what its reader has no room for); without a reader
// frames are dropped and the pipe is reopened at the next frame; a reader that comes back gets a
// new header (what the old one left unread goes with the old pipe).
class Y4mPipeWriter {
 public:
  enum class Result : std::uint8_t { kWritten, kNoReader, kReaderBehind, kReaderGone };

  // Creates the named pipe if it does not exist. Throws std::runtime_error if `path` is
  // something else or cannot be made.
  Y4mPipeWriter(std::string path, int width, int height, double fps);
  ~Y4mPipeWriter();
  Y4mPipeWriter(const Y4mPipeWriter&) = delete;
  Y4mPipeWriter& operator=(const Y4mPipeWriter&) = delete;

  Result write(const std::uint8_t* yuyv, int stride);
  const std::string& path() const { return path_; }

 private:
  enum class FlushResult : std::uint8_t { kDone, kPending, kGone };
  bool open();
  void closePipe();
  // Writes what is pending as far as the pipe takes it.
  FlushResult flush();

  std::string path_;
  int width_;
  int height_;
  double fps_;
  int fd_ = -1;
  // Bytes not yet in the pipe (a header, a frame's rest), from pending_start_ on.
  std::vector<std::uint8_t> pending_;
  std::size_t pending_start_ = 0;
};

}  // namespace fieldline::camera
