#include "services/motor_bridge/serial_link.hpp"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <optional>

namespace fieldline::motor_bridge {

namespace {

std::optional<speed_t> baudConstant(unsigned baud) {
  switch (baud) {
    case 1200:
      return B1200;
    case 2400:
      return B2400;
    case 4800:
      return B4800;
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 38400:
      return B38400;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
    case 460800:
      return B460800;
    case 500000:
      return B500000;
    case 576000:
      return B576000;
    case 921600:
      return B921600;
    case 1000000:
      return B1000000;
    case 1152000:
      return B1152000;
    case 1500000:
      return B1500000;
    case 2000000:
      return B2000000;
    case 2500000:
      return B2500000;
    case 3000000:
      return B3000000;
    case 3500000:
      return B3500000;
    case 4000000:
      return B4000000;
    default:
      return std::nullopt;
  }
}

// Raw 8N1 without flow control at `baud` (what Boost.Asio's serial_port options set before).
// Returns the errno of the step that failed, 0 on success.
int configure(int fd, unsigned baud) {
  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) return errno;
  ::cfmakeraw(&tio);
  const auto speed = baudConstant(baud);
  if (!speed) return EINVAL;
  if (::cfsetispeed(&tio, *speed) != 0 || ::cfsetospeed(&tio, *speed) != 0) return errno;
  tio.c_iflag |= IGNPAR;
  tio.c_iflag &= ~static_cast<tcflag_t>(IXOFF | IXON);
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS);
  tio.c_cflag |= CS8 | CREAD | CLOCAL;
  if (::tcsetattr(fd, TCSANOW, &tio) != 0) return errno;
  return 0;
}

}  // namespace

SerialLink::SerialLink(SerialLinkConfig config, BytesHandler on_bytes, StateHandler on_state)
    : config_(std::move(config)), on_bytes_(std::move(on_bytes)), on_state_(std::move(on_state)) {}

SerialLink::~SerialLink() {
  stop();
}

void SerialLink::start() {
  running_ = true;
  tryOpen();
}

void SerialLink::stop() {
  running_ = false;
  closeDevice();
}

void SerialLink::closeDevice() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  write_queue_.clear();
  front_written_ = 0;
}

void SerialLink::tryOpen() {
  if (!running_ || fd_ >= 0) return;
  const int fd = ::open(config_.device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  const int error = fd < 0 ? errno : configure(fd, config_.baud_rate);
  if (error != 0) {
    if (fd >= 0) ::close(fd);
    ++stats_.open_failures;
    last_error_ = "open " + config_.device + ": " + std::strerror(error);
    next_open_ =
        std::chrono::steady_clock::now() +
        std::chrono::microseconds(static_cast<std::int64_t>(config_.reconnect_interval * 1e6));
    return;
  }
  // Bytes that waited in the line while nobody listened are stale: start clean.
  ::tcflush(fd, TCIOFLUSH);
  fd_ = fd;
  ++stats_.opens;
  if (on_state_) on_state_(true);
}

void SerialLink::poll() {
  if (fd_ < 0) {
    if (running_ && std::chrono::steady_clock::now() >= next_open_) tryOpen();
    return;
  }
  if (!write_queue_.empty()) flushQueue();
}

void SerialLink::fail(const std::string& what) {
  last_error_ = what;
  closeDevice();
  ++stats_.disconnects;
  next_open_ =
      std::chrono::steady_clock::now() +
      std::chrono::microseconds(static_cast<std::int64_t>(config_.reconnect_interval * 1e6));
  if (on_state_) on_state_(false);
}

void SerialLink::onReadable() {
  if (fd_ < 0) return;
  const ssize_t n = ::read(fd_, read_buffer_.data(), read_buffer_.size());
  if (n > 0) {
    stats_.bytes_in += static_cast<std::uint64_t>(n);
    if (on_bytes_)
      on_bytes_(std::span<const std::uint8_t>(read_buffer_.data(), static_cast<std::size_t>(n)));
    return;
  }
  if (n == 0) {
    fail("read " + config_.device + ": End of file");
    return;
  }
  if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return;
  fail("read " + config_.device + ": " + std::strerror(errno));
}

bool SerialLink::send(std::span<const std::uint8_t> bytes) {
  if (fd_ < 0) {
    stats_.bytes_dropped += bytes.size();
    return false;
  }
  if (write_queue_.empty()) {
    // The usual case: the device takes the whole frame at once, nothing is queued or allocated.
    const ssize_t n = ::write(fd_, bytes.data(), bytes.size());
    if (n >= 0) stats_.bytes_out += static_cast<std::uint64_t>(n);
    if (n == static_cast<ssize_t>(bytes.size())) return true;
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
      fail("write " + config_.device + ": " + std::strerror(errno));
      return true;
    }
    write_queue_.emplace_back(bytes.begin(), bytes.end());
    front_written_ = n > 0 ? static_cast<std::size_t>(n) : 0;
    return true;
  }
  // A device that stopped taking bytes must not collect a backlog of stale commands that would
  // all go out (and feed the controller's watchdog) once it recovers: keep only the newest.
  // Room for the new frame first, so that at most kMaxQueuedFrames wait.
  while (write_queue_.size() >= kMaxQueuedFrames) {
    // The front frame may be partly written; drop the oldest one behind it then.
    auto oldest = write_queue_.begin() + (front_written_ > 0 ? 1 : 0);
    stats_.bytes_dropped += oldest->size();
    ++stats_.frames_dropped;
    write_queue_.erase(oldest);
  }
  write_queue_.emplace_back(bytes.begin(), bytes.end());
  flushQueue();
  return true;
}

void SerialLink::flushQueue() {
  while (fd_ >= 0 && !write_queue_.empty()) {
    const auto& front = write_queue_.front();
    const ssize_t n = ::write(fd_, front.data() + front_written_, front.size() - front_written_);
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return;
      fail("write " + config_.device + ": " + std::strerror(errno));
      return;
    }
    stats_.bytes_out += static_cast<std::uint64_t>(n);
    front_written_ += static_cast<std::size_t>(n);
    if (front_written_ < front.size()) return;
    write_queue_.pop_front();
    front_written_ = 0;
  }
}

}  // namespace fieldline::motor_bridge
