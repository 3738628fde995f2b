// Image-to-pose latency (issue 32 item 4): per robot, the time from a CAMERA_IMAGE's arrival on
// the robot's bus to the first ROBOT_STATE that includes the correction made from it.
//
// Only message stamps are used, all on the robot's own clock: the image's arrival is its
// header.utime_published (the camera publishes a frame when it is delivered: exposure plus the
// camera's own delay), the correction's image is ROBOT_STATE's header.utime - since_vision_us
// (fusion's last accepted vision correction, stamped with its frame's exposure time), and the
// state goes out at its header.utime_published. The camera's own delay (utime_published - utime
// of the frames) is reported beside it: the target is a p99 of at most 5 ms beyond it.
//
// The team's first seconds (every process starting at once, rasters built, filters searching)
// are left out: corrections from frames that arrived within `leave_out_s` of the robot's first
// frame are not counted (fieldline-eval passes its --settle), and line() says so.
#pragma once

#include <cmath>
#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "common/time/clock.hpp"

namespace fieldline::eval {

struct ImageToPoseFigures {
  // Corrections matched with their frame.
  std::size_t corrections = 0;
  // ... whose frame was not seen (older than the window kept, or lost).
  std::size_t unmatched = 0;
  // ... whose frame came within the left-out start (not in the quantiles).
  std::size_t left_out = 0;
  double p50_ms = 0.0, p99_ms = 0.0, max_ms = 0.0;
  // The camera's own delay (utime_published - utime of its frames), median.
  double camera_delay_ms = 0.0;
};

class ImageToPose {
 public:
  explicit ImageToPose(double leave_out_s = 0.0) : leave_out_us_(std::llround(leave_out_s * 1e6)) {}

  // A CAMERA_IMAGE of `robot`: its header.utime and header.utime_published.
  void onImage(int robot, Utime utime, Utime published);
  // A ROBOT_STATE of `robot`.
  void onState(int robot, Utime utime, std::int64_t since_vision_us, Utime published);

  std::map<int, ImageToPoseFigures> figures() const;
  // All robots together.
  ImageToPoseFigures total() const;
  // "image-to-pose latency: p50 1.2 ms, p99 3.4 ms beyond the camera's 60.0 ms (540 corrections,
  // 0 without their frame, 57 in the first 2.0 s left out); robot 1 ..."; "no corrections" when
  // there were none.
  std::string line() const;

 private:
  struct Robot {
    // Recent frames: (utime, utime_published), oldest first.
    std::deque<std::pair<Utime, Utime>> frames;
    Utime last_correction = 0;
    // The first frame's arrival: corrections of frames before it + leave_out_us_ are left out.
    Utime first_arrival = 0;
    std::size_t left_out = 0;
    std::vector<double> latencies_ms;
    std::vector<double> delays_ms;
    std::size_t unmatched = 0;
  };
  static ImageToPoseFigures figuresOf(std::vector<double> latencies, std::vector<double> delays,
                                      std::size_t unmatched, std::size_t left_out);
  Utime leave_out_us_;
  std::map<int, Robot> robots_;
};

}  // namespace fieldline::eval
