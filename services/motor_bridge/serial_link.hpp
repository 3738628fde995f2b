// A serial line that survives the device going away: the same code opens a real /dev/ttyUSB0 and
// the firmware emulator's pseudo-terminal. When a read or write fails (cable pulled, emulator
// restarted) it closes the device and tries again every reconnect_interval until it is back.
//
// Plain POSIX, driven by the caller's event loop (issue 32: Boost.Asio's reactor beside the bus
// node's poll() cost an epoll_wait per pump and a speculative read that found nothing): the caller
// waits on nativeHandle() and calls onReadable() when it is readable (or hung up), and calls
// poll() periodically (the command timer) to retry an open that is due and to write what the
// device did not take at once. send() writes at once; a frame is queued only when the device
// does not take it all.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <span>
#include <string>
#include <vector>

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

  SerialLink(SerialLinkConfig config, BytesHandler on_bytes, StateHandler on_state);
  ~SerialLink();
  SerialLink(const SerialLink&) = delete;
  SerialLink& operator=(const SerialLink&) = delete;

  // Opens the device now, or poll() retries every reconnect_interval; returns immediately.
  void start();
  // Closes the device and stops retrying.
  void stop();
  bool connected() const { return fd_ >= 0; }
  // The open device's file descriptor, for an event loop to wait on (then call onReadable());
  // -1 while closed. A new one after every reconnect.
  int nativeHandle() const { return fd_; }
  // Writes bytes (queued if the device does not take them all); when the link is down they are
  // dropped and counted (a command is worthless by the time the device returns). Returns false
  // then.
  bool send(std::span<const std::uint8_t> bytes);
  // Reads what the device holds, in one read, and hands it over; a read error or end of file
  // closes the link (and poll() reopens it). Call when nativeHandle() is readable or hung up.
  void onReadable();
  // Reopens the device when a retry is due and writes what waits in the queue. Cheap when there
  // is nothing to do; call it periodically (the bridge: every command tick).
  void poll();

  const SerialLinkStats& stats() const { return stats_; }
  const SerialLinkConfig& config() const { return config_; }
  // Why the last open or read failed (empty if none yet).
  const std::string& lastError() const { return last_error_; }

 private:
  void tryOpen();
  void closeDevice();
  void flushQueue();
  void fail(const std::string& what);

  SerialLinkConfig config_;
  BytesHandler on_bytes_;
  StateHandler on_state_;
  int fd_ = -1;
  bool running_ = false;
  // When poll() tries to open the device again (while it is closed and running_).
  std::chrono::steady_clock::time_point next_open_{};
  // Room for everything a pty holds (4 KB), so a backlog after a stall of the process is read in
  // one go: the bridge back-dates the samples of one read by their controller times, and a
  // backlog split over several reads would stamp all but the last part too late (found by the
  // kill drill, docs/drills.md).
  std::array<std::uint8_t, 16384> read_buffer_{};
  // Frames the device did not take at once; the front one's first front_written_ bytes are out.
  std::deque<std::vector<std::uint8_t>> write_queue_;
  std::size_t front_written_ = 0;
  SerialLinkStats stats_;
  std::string last_error_;
};

}  // namespace fieldline::motor_bridge
