// An example of a motor controller's own protocol, for teams whose firmware does not speak
// docs/serial-protocol.md: plain text lines over a serial line (docs/own-controller.md).
//
//   controller -> host, at its odometry rate:
//     O <t_us> <ticks_0> ... <ticks_n-1>   accumulated encoder ticks of the robot file's n wheels
//                                          (in its order), sampled at controller time t_us
//     S <t_us> <vx> <vy> <omega>           or, from a controller without wheel ticks: its body
//                                          velocity at t_us (m/s forward, m/s left, rad/s CCW)
//     # anything                           a comment (firmware messages), ignored
//   host -> controller, at the command rate:
//     V <vx> <vy> <omega>                  body velocity to drive (m/s, m/s, rad/s); zero when
//                                          the command expired
//
// One line ends with '\n' ('\r' before it is ignored); fields are separated by spaces or tabs.
// This header parses and formats lines and knows nothing of devices or time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <variant>

#include <boost/container/static_vector.hpp>

namespace fieldline::motor_bridge::text {

// A longer line is garbage (a controller talking another protocol, line noise).
inline constexpr std::size_t kMaxLineLength = 200;
inline constexpr std::size_t kMaxWheels = 4;

// O: accumulated ticks at a controller time.
struct TickLine {
  std::int64_t controller_time_us = 0;
  boost::container::static_vector<std::int32_t, kMaxWheels> ticks;
};

// S: the body velocity a controller without ticks measured.
struct VelocityLine {
  std::int64_t controller_time_us = 0;
  double vx = 0.0;
  double vy = 0.0;
  double omega = 0.0;
};

struct Comment {};

// What is wrong with a line, for counters ("text_malformed") and the log.
struct LineError {
  std::string what;
};

using Line = std::variant<TickLine, VelocityLine, Comment, LineError>;

// Parses one line without its terminator.
Line parseLine(std::string_view line);
// "V <vx> <vy> <omega>\n" with enough digits for a millimetre per second.
std::string formatCommand(double vx, double vy, double omega);

// Cuts a byte stream into lines: feed bytes as they arrive; complete lines come out once, a line
// longer than kMaxLineLength is dropped up to its end (counted in overlong()).
class LineSplitter {
 public:
  template <typename Fn>
  void feed(std::string_view bytes, Fn&& on_line) {
    for (const char c : bytes) {
      if (c == '\n') {
        if (!skipping_) {
          if (!line_.empty() && line_.back() == '\r') line_.pop_back();
          on_line(std::string_view(line_));
        }
        line_.clear();
        skipping_ = false;
      } else if (!skipping_) {
        line_.push_back(c);
        if (line_.size() > kMaxLineLength) {
          ++overlong_;
          line_.clear();
          skipping_ = true;
        }
      }
    }
  }
  void reset() {
    line_.clear();
    skipping_ = false;
  }
  std::uint64_t overlong() const { return overlong_; }

 private:
  std::string line_;
  bool skipping_ = false;
  std::uint64_t overlong_ = 0;
};

}  // namespace fieldline::motor_bridge::text
