#include "services/camera/sources_y4m.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

namespace fieldline::camera {
namespace {

constexpr std::size_t kMaxLine = 1024;
constexpr std::size_t kReadChunk = 1 << 16;
// The pipe's size asked for: one 640x480 4:2:2 frame and its header (1 MiB is what an
// unprivileged process may ask for by default, /proc/sys/fs/pipe-max-size).
constexpr int kPipeBytes = 1 << 20;

std::int64_t nowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

int parsePositive(const std::string& text, const std::string& what, int largest = 16384) {
  std::size_t used = 0;
  int v = 0;
  try {
    v = std::stoi(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || v <= 0 || v > largest) {
    throw std::runtime_error("YUV4MPEG2 header: bad " + what + " '" + text + "'");
  }
  return v;
}

}  // namespace

std::size_t Y4mFormat::frameBytes() const {
  const auto w = static_cast<std::size_t>(width);
  const auto h = static_cast<std::size_t>(height);
  switch (chroma) {
    case Chroma::k422:
      return w * h * 2;
    case Chroma::k420:
      return w * h + 2 * (w / 2) * ((h + 1) / 2);
    case Chroma::kMono:
      return w * h;
  }
  return 0;
}

Y4mFormat parseY4mHeader(const std::string& line) {
  std::istringstream words(line);
  std::string magic;
  words >> magic;
  if (magic != "YUV4MPEG2") {
    throw std::runtime_error("not a YUV4MPEG2 stream (it starts with '" + line.substr(0, 20) +
                             "')");
  }
  Y4mFormat f;
  for (std::string tag; words >> tag;) {
    const char key = tag[0];
    const std::string value = tag.substr(1);
    if (key == 'W') f.width = parsePositive(value, "width");
    if (key == 'H') f.height = parsePositive(value, "height");
    if (key == 'F') {
      const auto colon = value.find(':');
      constexpr int kLargest = 1 << 30;
      const int num = parsePositive(value.substr(0, colon), "frame rate", kLargest);
      const int den = colon == std::string::npos
                          ? 1
                          : parsePositive(value.substr(colon + 1), "frame rate", kLargest);
      f.fps = static_cast<double>(num) / den;
    }
    if (key == 'C') {
      if (value == "422") {
        f.chroma = Y4mFormat::Chroma::k422;
      } else if (value == "420" || value == "420jpeg" || value == "420paldv" ||
                 value == "420mpeg2") {
        f.chroma = Y4mFormat::Chroma::k420;
      } else if (value == "mono") {
        f.chroma = Y4mFormat::Chroma::kMono;
      } else {
        throw std::runtime_error("YUV4MPEG2 colour space C" + value +
                                 " is not read (422, 420 or mono; ffmpeg: -pix_fmt yuv422p)");
      }
    }
  }
  if (f.width == 0 || f.height == 0) throw std::runtime_error("YUV4MPEG2 header without W and H");
  if (f.width % 2 != 0) {
    throw std::runtime_error(fmt::format("YUV4MPEG2 width {} is odd (YUYV pairs pixels)", f.width));
  }
  return f;
}

std::string y4mHeader(int width, int height, double fps) {
  const int millihertz = static_cast<int>(std::lround(fps * 1000.0));
  return fmt::format("YUV4MPEG2 W{} H{} F{}:1000 Ip A1:1 C422\n", width, height,
                     std::max(1, millihertz));
}

void y4mPlanesToYuyv(const Y4mFormat& format, const std::uint8_t* planes, std::uint8_t* yuyv) {
  const int w = format.width;
  const int h = format.height;
  const std::uint8_t* y_plane = planes;
  const int cw = w / 2;
  const int ch = format.chroma == Y4mFormat::Chroma::k420 ? (h + 1) / 2 : h;
  const std::uint8_t* u_plane = y_plane + static_cast<std::size_t>(w) * h;
  const std::uint8_t* v_plane = u_plane + static_cast<std::size_t>(cw) * ch;
  for (int v = 0; v < h; ++v) {
    const std::uint8_t* y = y_plane + static_cast<std::size_t>(v) * w;
    std::uint8_t* out = yuyv + static_cast<std::size_t>(v) * w * 2;
    if (format.chroma == Y4mFormat::Chroma::kMono) {
      for (int k = 0; k < cw; ++k) {
        out[4 * k] = y[2 * k];
        out[4 * k + 1] = 128;
        out[4 * k + 2] = y[2 * k + 1];
        out[4 * k + 3] = 128;
      }
      continue;
    }
    const int row = format.chroma == Y4mFormat::Chroma::k420 ? v / 2 : v;
    const std::uint8_t* u = u_plane + static_cast<std::size_t>(row) * cw;
    const std::uint8_t* vv = v_plane + static_cast<std::size_t>(row) * cw;
    for (int k = 0; k < cw; ++k) {
      out[4 * k] = y[2 * k];
      out[4 * k + 1] = u[k];
      out[4 * k + 2] = y[2 * k + 1];
      out[4 * k + 3] = vv[k];
    }
  }
}

void yuyvToY4mPlanes(const std::uint8_t* yuyv, int width, int height, int stride,
                     std::uint8_t* planes) {
  const int cw = width / 2;
  std::uint8_t* y_plane = planes;
  std::uint8_t* u_plane = y_plane + static_cast<std::size_t>(width) * height;
  std::uint8_t* v_plane = u_plane + static_cast<std::size_t>(cw) * height;
  for (int v = 0; v < height; ++v) {
    const std::uint8_t* in = yuyv + static_cast<std::size_t>(v) * stride;
    std::uint8_t* y = y_plane + static_cast<std::size_t>(v) * width;
    std::uint8_t* u = u_plane + static_cast<std::size_t>(v) * cw;
    std::uint8_t* vv = v_plane + static_cast<std::size_t>(v) * cw;
    for (int k = 0; k < cw; ++k) {
      y[2 * k] = in[4 * k];
      u[k] = in[4 * k + 1];
      y[2 * k + 1] = in[4 * k + 2];
      vv[k] = in[4 * k + 3];
    }
  }
}

// --- Y4mPipeSource ---

Y4mPipeSource::Y4mPipeSource(std::string path, double frame_timeout_s)
    : path_(std::move(path)), frame_timeout_s_(frame_timeout_s) {
  // Without O_NONBLOCK, opening a pipe waits for its writer; reads wait in poll() instead.
  fd_ = ::open(path_.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) throw std::runtime_error(path_ + ": cannot open: " + std::strerror(errno));
}

Y4mPipeSource::~Y4mPipeSource() {
  if (fd_ >= 0) ::close(fd_);
}

std::string Y4mPipeSource::describe() const {
  if (!have_header_) return path_ + " (YUV4MPEG2 pipe, no frame yet)";
  return fmt::format("{} (YUV4MPEG2 pipe) {}x{} {} -> YUYV", path_, format_.width, format_.height,
                     format_.chroma == Y4mFormat::Chroma::k422   ? "4:2:2"
                     : format_.chroma == Y4mFormat::Chroma::k420 ? "4:2:0"
                                                                 : "mono");
}

bool Y4mPipeSource::fill(std::int64_t deadline_ms) {
  if (buffer_start_ > 0 && buffer_start_ * 2 > buffer_.size()) {
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(buffer_start_));
    buffer_start_ = 0;
  }
  for (;;) {
    // Wait first: a pipe that no writer has opened yet reads as its end, but polls as quiet
    // (only a writer that came and went makes it report a hang-up).
    const std::int64_t left = deadline_ms - nowMs();
    if (left <= 0) {
      noteProblem(fmt::format("{}: no frame for {:g} s (is anything writing into the pipe?)", path_,
                              frame_timeout_s_));
      return false;
    }
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::min<std::int64_t>(left, 1000)));
    if (ready <= 0) continue;
    const std::size_t old = buffer_.size();
    buffer_.resize(old + kReadChunk);
    const ssize_t n = ::read(fd_, buffer_.data() + old, kReadChunk);
    buffer_.resize(old + static_cast<std::size_t>(std::max<ssize_t>(n, 0)));
    if (n > 0) return true;
    if (n == 0) {
      noteProblem(path_ + ": the writer closed the pipe");
      return false;
    }
    if (errno != EAGAIN && errno != EINTR) {
      noteProblem(path_ + ": " + std::strerror(errno));
      return false;
    }
  }
}

bool Y4mPipeSource::readLine(std::string& line, std::int64_t deadline_ms) {
  std::size_t searched = buffer_start_;
  for (;;) {
    const auto begin = buffer_.begin() + static_cast<std::ptrdiff_t>(searched);
    const auto nl = std::find(begin, buffer_.end(), std::uint8_t{'\n'});
    if (nl != buffer_.end()) {
      line.assign(buffer_.begin() + static_cast<std::ptrdiff_t>(buffer_start_), nl);
      buffer_start_ = static_cast<std::size_t>(nl - buffer_.begin()) + 1;
      return true;
    }
    if (buffer_.size() - buffer_start_ > kMaxLine) {
      noteProblem(path_ + ": a YUV4MPEG2 line longer than 1024 bytes: not a YUV4MPEG2 stream");
      return false;
    }
    searched = buffer_.size() - buffer_start_;
    if (!fill(deadline_ms)) return false;
    searched += buffer_start_;
  }
}

bool Y4mPipeSource::readBytes(std::uint8_t* out, std::size_t n, std::int64_t deadline_ms) {
  while (buffer_.size() - buffer_start_ < n) {
    if (!fill(deadline_ms)) return false;
  }
  std::memcpy(out, buffer_.data() + buffer_start_, n);
  buffer_start_ += n;
  return true;
}

bool Y4mPipeSource::next(SourceFrame& out) {
  const std::int64_t deadline = nowMs() + static_cast<std::int64_t>(frame_timeout_s_ * 1000.0);
  std::string line;
  if (!have_header_) {
    if (!readLine(line, deadline)) return false;
    try {
      format_ = parseY4mHeader(line);
    } catch (const std::runtime_error& e) {
      noteProblem(path_ + ": " + e.what());
      return false;
    }
    have_header_ = true;
    planes_.resize(format_.frameBytes());
  }
  if (!readLine(line, deadline)) return false;
  if (!line.starts_with("FRAME")) {
    noteProblem(path_ + ": expected a FRAME line, got '" + line.substr(0, 20) + "'");
    return false;
  }
  if (!readBytes(planes_.data(), planes_.size(), deadline)) return false;
  out.width = format_.width;
  out.height = format_.height;
  out.stride = format_.width * 2;
  out.format = PixelFormat::kYuyv;
  out.bytes.resize(static_cast<std::size_t>(out.stride) * out.height);
  y4mPlanesToYuyv(format_, planes_.data(), out.bytes.data());
  out.frame_number = delivered_++;
  out.recorded_utime.reset();
  return true;
}

// --- Y4mPipeWriter ---

Y4mPipeWriter::Y4mPipeWriter(std::string path, int width, int height, double fps)
    : path_(std::move(path)), width_(width), height_(height), fps_(fps) {
  if (width_ <= 0 || height_ <= 0 || width_ % 2 != 0) {
    throw std::runtime_error(
        fmt::format("{}: cannot write {}x{} as YUYV pairs", path_, width_, height_));
  }
  struct stat st {};
  if (::stat(path_.c_str(), &st) != 0) {
    if (::mkfifo(path_.c_str(), 0660) != 0) {
      throw std::runtime_error(path_ + ": cannot make the named pipe: " + std::strerror(errno));
    }
  } else if (!S_ISFIFO(st.st_mode)) {
    throw std::runtime_error(path_ + ": exists and is not a named pipe");
  }
  // A reader that goes away must not end the process.
  std::signal(SIGPIPE, SIG_IGN);
}

Y4mPipeWriter::~Y4mPipeWriter() {
  if (fd_ >= 0) ::close(fd_);
}

bool Y4mPipeWriter::open() {
  fd_ = ::open(path_.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) return false;  // ENXIO: no reader yet
  (void)::fcntl(fd_, F_SETPIPE_SZ, kPipeBytes);
  const std::string header = y4mHeader(width_, height_, fps_);
  pending_.assign(header.begin(), header.end());
  pending_start_ = 0;
  return flush() != FlushResult::kGone;
}

void Y4mPipeWriter::closePipe() {
  ::close(fd_);
  fd_ = -1;
  pending_.clear();
  pending_start_ = 0;
}

Y4mPipeWriter::FlushResult Y4mPipeWriter::flush() {
  while (pending_start_ < pending_.size()) {
    const ssize_t w =
        ::write(fd_, pending_.data() + pending_start_, pending_.size() - pending_start_);
    if (w > 0) {
      pending_start_ += static_cast<std::size_t>(w);
      continue;
    }
    if (w < 0 && (errno == EAGAIN || errno == EINTR)) return FlushResult::kPending;
    closePipe();  // EPIPE: the reader went away
    return FlushResult::kGone;
  }
  pending_.clear();
  pending_start_ = 0;
  return FlushResult::kDone;
}

Y4mPipeWriter::Result Y4mPipeWriter::write(const std::uint8_t* yuyv, int stride) {
  if (fd_ >= 0) {
    // The reader went away (a pipe's writer then polls as an error): close, so that what it left
    // unread is dropped with the pipe and the next reader starts with a header.
    pollfd p{fd_, POLLOUT, 0};
    if (::poll(&p, 1, 0) > 0 && (p.revents & (POLLERR | POLLHUP)) != 0) closePipe();
  }
  if (fd_ < 0 && !open()) return Result::kNoReader;
  // The rest of an earlier frame goes first; while it does not fit, new frames are dropped (a
  // camera drops what its reader has no room for; nothing here ever blocks).
  switch (flush()) {
    case FlushResult::kGone:
      return Result::kReaderGone;
    case FlushResult::kPending:
      return Result::kReaderBehind;
    case FlushResult::kDone:
      break;
  }
  pending_.resize(6 + static_cast<std::size_t>(width_) * height_ * 2);
  std::memcpy(pending_.data(), "FRAME\n", 6);
  yuyvToY4mPlanes(yuyv, width_, height_, stride, pending_.data() + 6);
  pending_start_ = 0;
  return flush() == FlushResult::kGone ? Result::kReaderGone : Result::kWritten;
}

}  // namespace fieldline::camera
