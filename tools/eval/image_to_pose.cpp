#include "tools/eval/image_to_pose.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace fieldline::eval {
namespace {

// Frames kept per robot to find a correction's frame: 10 s at 30 Hz (a correction comes within
// a few frames of its image; fusion refuses older ones).
constexpr std::size_t kFramesKept = 300;

double quantile(std::vector<double>& v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(std::lround(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace

void ImageToPose::onImage(int robot, Utime utime, Utime published) {
  Robot& r = robots_[robot];
  if (r.frames.empty() && r.first_arrival == 0) r.first_arrival = published;
  r.frames.emplace_back(utime, published);
  if (r.frames.size() > kFramesKept) r.frames.pop_front();
  r.delays_ms.push_back(static_cast<double>(published - utime) / 1000.0);
}

void ImageToPose::onState(int robot, Utime utime, std::int64_t since_vision_us, Utime published) {
  // 0: no correction yet.
  if (since_vision_us <= 0) return;
  Robot& r = robots_[robot];
  const Utime correction = utime - since_vision_us;
  if (correction == r.last_correction) return;  // already counted at its first state
  r.last_correction = correction;
  const auto frame = std::find_if(r.frames.rbegin(), r.frames.rend(),
                                  [&](const auto& f) { return f.first == correction; });
  if (frame == r.frames.rend()) {
    ++r.unmatched;
    return;
  }
  if (frame->second < r.first_arrival + leave_out_us_) {
    ++r.left_out;
    return;
  }
  r.latencies_ms.push_back(static_cast<double>(published - frame->second) / 1000.0);
}

ImageToPoseFigures ImageToPose::figuresOf(std::vector<double> latencies, std::vector<double> delays,
                                          std::size_t unmatched, std::size_t left_out) {
  ImageToPoseFigures f;
  f.corrections = latencies.size();
  f.unmatched = unmatched;
  f.left_out = left_out;
  if (!latencies.empty()) f.max_ms = *std::max_element(latencies.begin(), latencies.end());
  f.p50_ms = quantile(latencies, 0.5);
  f.p99_ms = quantile(latencies, 0.99);
  f.camera_delay_ms = quantile(delays, 0.5);
  return f;
}

std::map<int, ImageToPoseFigures> ImageToPose::figures() const {
  std::map<int, ImageToPoseFigures> out;
  for (const auto& [robot, r] : robots_)
    out[robot] = figuresOf(r.latencies_ms, r.delays_ms, r.unmatched, r.left_out);
  return out;
}

ImageToPoseFigures ImageToPose::total() const {
  std::vector<double> latencies, delays;
  std::size_t unmatched = 0;
  std::size_t left_out = 0;
  for (const auto& [robot, r] : robots_) {
    latencies.insert(latencies.end(), r.latencies_ms.begin(), r.latencies_ms.end());
    delays.insert(delays.end(), r.delays_ms.begin(), r.delays_ms.end());
    unmatched += r.unmatched;
    left_out += r.left_out;
  }
  return figuresOf(std::move(latencies), std::move(delays), unmatched, left_out);
}

std::string ImageToPose::line() const {
  const ImageToPoseFigures all = total();
  if (all.corrections == 0) return "image-to-pose latency: no corrections matched with their frame";
  std::string out = fmt::format(
      "image-to-pose latency: p50 {:.1f} ms, p99 {:.1f} ms beyond the camera's own {:.1f} ms "
      "({} corrections, {} without their frame, {} in the first {:.1f} s left out)",
      all.p50_ms, all.p99_ms, all.camera_delay_ms, all.corrections, all.unmatched, all.left_out,
      static_cast<double>(leave_out_us_) * 1e-6);
  for (const auto& [robot, f] : figures()) {
    out += fmt::format("; robot {} p50 {:.1f} p99 {:.1f} ms", robot, f.p50_ms, f.p99_ms);
  }
  return out;
}

}  // namespace fieldline::eval
