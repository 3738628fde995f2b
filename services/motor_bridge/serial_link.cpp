#include "services/motor_bridge/serial_link.hpp"

#include <termios.h>

#include <chrono>

#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>

namespace fieldline::motor_bridge {

namespace asio = boost::asio;

SerialLink::SerialLink(asio::io_context& io, SerialLinkConfig config, BytesHandler on_bytes,
                       StateHandler on_state)
    : io_(io),
      config_(std::move(config)),
      on_bytes_(std::move(on_bytes)),
      on_state_(std::move(on_state)),
      port_(io),
      retry_timer_(io) {}

SerialLink::~SerialLink() {
  stop();
}

void SerialLink::start() {
  running_ = true;
  tryOpen();
}

void SerialLink::stop() {
  running_ = false;
  retry_timer_.cancel();
  if (port_.is_open()) {
    boost::system::error_code ignored;
    port_.close(ignored);
    ++generation_;
  }
  write_queue_.clear();
  writing_ = false;
}

void SerialLink::tryOpen() {
  if (!running_) return;
  boost::system::error_code ec;
  port_.open(config_.device, ec);
  if (!ec) port_.set_option(asio::serial_port::baud_rate(config_.baud_rate), ec);
  if (!ec) port_.set_option(asio::serial_port::character_size(8), ec);
  if (!ec) port_.set_option(asio::serial_port::parity(asio::serial_port::parity::none), ec);
  if (!ec) port_.set_option(asio::serial_port::stop_bits(asio::serial_port::stop_bits::one), ec);
  if (!ec) {
    port_.set_option(asio::serial_port::flow_control(asio::serial_port::flow_control::none), ec);
  }
  if (ec) {
    if (port_.is_open()) {
      boost::system::error_code ignored;
      port_.close(ignored);
    }
    ++stats_.open_failures;
    last_error_ = "open " + config_.device + ": " + ec.message();
    scheduleReconnect();
    return;
  }
  // Bytes that waited in the line while nobody listened are stale: start clean.
  ::tcflush(port_.native_handle(), TCIOFLUSH);
  ++stats_.opens;
  ++generation_;
  startRead();
  if (on_state_) on_state_(true);
}

void SerialLink::scheduleReconnect() {
  if (!running_) return;
  retry_timer_.expires_after(
      std::chrono::microseconds(static_cast<std::int64_t>(config_.reconnect_interval * 1e6)));
  retry_timer_.async_wait([this](const boost::system::error_code& ec) {
    if (!ec) tryOpen();
  });
}

void SerialLink::fail(const std::string& what) {
  last_error_ = what;
  if (port_.is_open()) {
    boost::system::error_code ignored;
    port_.close(ignored);
  }
  ++generation_;
  ++stats_.disconnects;
  write_queue_.clear();
  writing_ = false;
  if (on_state_) on_state_(false);
  scheduleReconnect();
}

void SerialLink::startRead() {
  const std::uint64_t generation = generation_;
  port_.async_read_some(asio::buffer(read_buffer_),
                        [this, generation](const boost::system::error_code& ec, std::size_t n) {
                          if (generation != generation_)
                            return;  // from a connection already closed
                          if (ec) {
                            fail("read " + config_.device + ": " + ec.message());
                            return;
                          }
                          stats_.bytes_in += n;
                          if (on_bytes_)
                            on_bytes_(std::span<const std::uint8_t>(read_buffer_.data(), n));
                          if (generation == generation_) startRead();
                        });
}

bool SerialLink::send(std::span<const std::uint8_t> bytes) {
  if (!port_.is_open()) {
    stats_.bytes_dropped += bytes.size();
    return false;
  }
  // A device that stopped taking bytes must not collect a backlog of stale commands that would
  // all go out (and feed the controller's watchdog) once it recovers: keep only the newest.
  while (write_queue_.size() > kMaxQueuedFrames) {
    // The front frame may be in flight; drop the oldest one behind it.
    auto oldest = write_queue_.begin() + (writing_ ? 1 : 0);
    stats_.bytes_dropped += oldest->size();
    ++stats_.frames_dropped;
    write_queue_.erase(oldest);
  }
  write_queue_.emplace_back(bytes.begin(), bytes.end());
  if (!writing_) startWrite();
  return true;
}

void SerialLink::startWrite() {
  if (write_queue_.empty()) {
    writing_ = false;
    return;
  }
  writing_ = true;
  const std::uint64_t generation = generation_;
  asio::async_write(port_, asio::buffer(write_queue_.front()),
                    [this, generation](const boost::system::error_code& ec, std::size_t n) {
                      if (generation != generation_) return;
                      if (ec) {
                        fail("write " + config_.device + ": " + ec.message());
                        return;
                      }
                      stats_.bytes_out += n;
                      write_queue_.pop_front();
                      startWrite();
                    });
}

}  // namespace fieldline::motor_bridge
