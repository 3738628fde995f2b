// A serial line through Boost.Asio that survives the device going away: the same code opens a
// real /dev/ttyUSB0 and the firmware emulator's pseudo-terminal. When a read or write fails
// (cable pulled, emulator restarted) it closes the port and tries again every
// reconnect_interval until the device is back.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <boost/asio/serial_port.hpp>
#include <boost/asio/steady_timer.hpp>

namespace fieldline::motor_bridge {

struct SerialLinkConfig {
  // Device path, e.g. /dev/ttyUSB0 or /tmp/fieldline/robot1.tty.
  std::string device;
  // [baud]; 8 data bits, no parity, one stop bit, no flow control.
  unsigned baud_rate = 115200;
  // Seconds between attempts to (re)open the device.
  double reconnect_interval = 0.25;
};

struct SerialLinkStats {
  std::uint64_t opens = 0;
  std::uint64_t open_failures = 0;
  std::uint64_t disconnects = 0;
  std::uint64_t bytes_in = 0;
  std::uint64_t bytes_out = 0;
  // Bytes handed to send() while the link was down, or dropped from a full write queue.
  std::uint64_t bytes_dropped = 0;
  // Frames dropped from a full write queue (the device stopped taking bytes).
  std::uint64_t frames_dropped = 0;
};

class SerialLink {
 public:
  // Frames waiting to be written at most; older ones are dropped first.
  static constexpr std::size_t kMaxQueuedFrames = 4;

  using BytesHandler = std::function<void(std::span<const std::uint8_t>)>;
  // Called with true after every successful open, false after every loss.
  using StateHandler = std::function<void(bool connected)>;

  SerialLink(boost::asio::io_context& io, SerialLinkConfig config, BytesHandler on_bytes,
             StateHandler on_state);
  ~SerialLink();
  SerialLink(const SerialLink&) = delete;
  SerialLink& operator=(const SerialLink&) = delete;

  // Opens the device now or schedules retries; returns immediately.
  void start();
  // Closes the device and stops retrying.
  void stop();
  bool connected() const { return port_.is_open(); }
  // The open device's file descriptor, for an event loop to wait on (then run the io_context
  // when it is readable); -1 while closed. A new one after every reconnect.
  int nativeHandle() { return port_.is_open() ? port_.native_handle() : -1; }
  // Queues bytes for writing; when the link is down they are dropped and counted (a command
  // is worthless by the time the device returns). Returns false then.
  bool send(std::span<const std::uint8_t> bytes);

  const SerialLinkStats& stats() const { return stats_; }
  const SerialLinkConfig& config() const { return config_; }
  // Why the last open or read failed (empty if none yet).
  const std::string& lastError() const { return last_error_; }

 private:
  void tryOpen();
  void scheduleReconnect();
  void startRead();
  void startWrite();
  void fail(const std::string& what);

  boost::asio::io_context& io_;
  SerialLinkConfig config_;
  BytesHandler on_bytes_;
  StateHandler on_state_;
  boost::asio::serial_port port_;
  boost::asio::steady_timer retry_timer_;
  // Room for everything a pty holds (4 KB), so a backlog after a stall of the process is read in
  // one go: the bridge back-dates the samples of one read by their controller times, and a
  // backlog split over several reads would stamp all but the last part too late (found by the
  // kill drill, docs/drills.md).
  std::array<std::uint8_t, 16384> read_buffer_{};
  std::deque<std::vector<std::uint8_t>> write_queue_;
  bool writing_ = false;
  bool running_ = false;
  // Bumped on every close so callbacks of an old connection are ignored.
  std::uint64_t generation_ = 0;
  SerialLinkStats stats_;
  std::string last_error_;
};

}  // namespace fieldline::motor_bridge
