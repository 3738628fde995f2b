#include "tools/viewer/camera_view.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tools/viewer/team_view.hpp"

namespace fieldline::viewer {

namespace {

template <typename T>
void keepAtMost(std::deque<T>& ring, std::size_t n) {
  while (ring.size() > n)
    ring.pop_front();
}

void writeLines(std::string& out, const line_contours_t& m) {
  json::Object o(out);
  o.integer("utime", m.header.utime);
  o.integer("seq", m.header.seq);
  o.integer("num_points", m.num_points);
  o.numbers("u", m.u.data(), m.u.size());
  o.numbers("v", m.v.data(), m.v.size());
  std::string& s = o.key("sequences");
  s += '[';
  for (int i = 0; i < m.num_sequences; ++i) {
    if (i > 0) s += ',';
    s += '[' + std::to_string(m.sequence_start[i]) + ',' + std::to_string(m.sequence_end[i]) + ']';
  }
  s += ']';
}

void writeBall(std::string& out, const ball_observation_t& m) {
  json::Object o(out);
  o.integer("utime", m.header.utime);
  o.integer("seq", m.header.seq);
  o.boolean("visible", m.visible);
  o.number("u", m.u);
  o.number("v", m.v);
}

}  // namespace

CameraView::CameraView(CameraViewOptions options) : options_(options) {
  if (!(options_.max_rate_hz > 0.0) || options_.jpeg_quality < 1 || options_.jpeg_quality > 100 ||
      options_.frames_kept < 1) {
    throw std::invalid_argument(
        "camera view: max_rate_hz must be > 0, jpeg_quality in 1..100, frames_kept >= 1");
  }
}

void CameraView::select(int robot) {
  if (robot == selected_) return;
  selected_ = robot;
  frames_.clear();
  lines_.clear();
  balls_.clear();
  lines_seen_ = false;
  encoded_once_ = false;
  last_encoded_utime_ = 0;
}

void CameraView::onImage(int robot, const image_t& image) {
  if (robot != selected_ || robot == 0) return;
  // Reuse the oldest slot's buffers once the ring is full: no allocation per frame.
  if (frames_.size() >= options_.frames_kept) {
    image_t slot = std::move(frames_.front());
    frames_.pop_front();
    slot = image;
    frames_.push_back(std::move(slot));
  } else {
    frames_.push_back(image);
  }
}

void CameraView::onLines(int robot, const line_contours_t& lines, Utime now) {
  if (robot != selected_ || robot == 0) return;
  lines_.push_back(lines);
  keepAtMost(lines_, 4);
  last_lines_received_ = now;
  lines_seen_ = true;
}

void CameraView::onBall(int robot, const ball_observation_t& ball) {
  if (robot != selected_ || robot == 0) return;
  balls_.push_back(ball);
  keepAtMost(balls_, options_.frames_kept);
}

std::optional<std::string> CameraView::update(Utime now) {
  if (selected_ == 0 || frames_.empty()) return std::nullopt;
  const auto period = static_cast<Utime>(std::llround(kMicrosPerSecond / options_.max_rate_hz));
  if (encoded_once_ && now - last_encode_ < period) return std::nullopt;

  // The newest frame the tracker's lines came for; else, with no lines for a while, the newest.
  const image_t* frame = nullptr;
  const line_contours_t* lines = nullptr;
  for (auto l = lines_.rbegin(); l != lines_.rend() && !frame; ++l) {
    if (l->header.utime <= last_encoded_utime_) break;
    for (const image_t& f : frames_) {
      if (f.header.utime == l->header.utime) {
        frame = &f;
        lines = &*l;
        break;
      }
    }
  }
  if (!frame && (!lines_seen_ || now - last_lines_received_ > options_.lines_missing_after_us) &&
      frames_.back().header.utime > last_encoded_utime_) {
    frame = &frames_.back();
  }
  if (!frame) return std::nullopt;
  const ball_observation_t* ball = nullptr;
  for (const ball_observation_t& b : balls_) {
    if (b.header.utime == frame->header.utime) ball = &b;
  }

  std::vector<std::uint8_t> jpeg;
  last_encode_ = now;
  encoded_once_ = true;
  last_encoded_utime_ = frame->header.utime;
  try {
    jpeg = encodeJpeg(*frame, options_.jpeg_quality);
  } catch (const std::exception& e) {
    ++frames_refused_;
    last_problem_ = e.what();
    return std::nullopt;
  }
  ++frames_encoded_;

  std::string out;
  out.reserve(jpeg.size() * 4 / 3 + 64 + (lines ? 24 * lines->num_points : 0));
  {
    json::Object doc(out);
    doc.integer("robot", selected_);
    {
      json::Object f(doc.key("frame"));
      f.integer("utime", frame->header.utime);
      f.integer("seq", frame->header.seq);
      f.integer("frame_number", frame->frame_number);
      f.integer("width", frame->width);
      f.integer("height", frame->height);
      f.integer("jpeg_bytes", static_cast<std::int64_t>(jpeg.size()));
      f.string("jpeg", base64(jpeg));
    }
    if (lines)
      writeLines(doc.key("lines"), *lines);
    else
      doc.key("lines") += "null";
    if (ball)
      writeBall(doc.key("ball"), *ball);
    else
      doc.key("ball") += "null";
    doc.integer("encoded", frames_encoded_);
  }
  return out;
}

std::vector<std::uint8_t> encodeJpeg(const image_t& image, int quality) {
  int type = 0, bytes_per_pixel = 0;
  switch (image.format) {
    case image_t::FORMAT_YUYV:
      type = CV_8UC2;
      bytes_per_pixel = 2;
      break;
    case image_t::FORMAT_BGR:
      type = CV_8UC3;
      bytes_per_pixel = 3;
      break;
    case image_t::FORMAT_GRAY:
      type = CV_8UC1;
      bytes_per_pixel = 1;
      break;
    default:
      throw std::invalid_argument("camera view: unknown image format " +
                                  std::to_string(image.format));
  }
  if (image.width <= 0 || image.height <= 0 || image.stride < image.width * bytes_per_pixel ||
      (image.format == image_t::FORMAT_YUYV && image.width % 2 != 0) ||
      image.data.size() <
          static_cast<std::size_t>(image.stride) * static_cast<std::size_t>(image.height)) {
    throw std::invalid_argument("camera view: image sizes do not fit its data");
  }
  // OpenCV only reads through this header (the const_cast is for its constructor's signature).
  const cv::Mat raw(image.height, image.width, type, const_cast<std::uint8_t*>(image.data.data()),
                    static_cast<std::size_t>(image.stride));
  cv::Mat bgr;
  if (image.format == image_t::FORMAT_YUYV)
    cv::cvtColor(raw, bgr, cv::COLOR_YUV2BGR_YUYV);
  else
    bgr = raw;
  std::vector<std::uint8_t> jpeg;
  if (!cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, quality})) {
    throw std::invalid_argument("camera view: JPEG encoding failed");
  }
  return jpeg;
}

std::string base64(const std::vector<std::uint8_t>& bytes) {
  static constexpr char kDigits[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 3 <= bytes.size(); i += 3) {
    const std::uint32_t n = (bytes[i] << 16) | (bytes[i + 1] << 8) | bytes[i + 2];
    out += kDigits[(n >> 18) & 63];
    out += kDigits[(n >> 12) & 63];
    out += kDigits[(n >> 6) & 63];
    out += kDigits[n & 63];
  }
  if (const std::size_t rest = bytes.size() - i; rest > 0) {
    const std::uint32_t n = (bytes[i] << 16) | (rest == 2 ? bytes[i + 1] << 8 : 0);
    out += kDigits[(n >> 18) & 63];
    out += kDigits[(n >> 12) & 63];
    out += rest == 2 ? kDigits[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

}  // namespace fieldline::viewer
