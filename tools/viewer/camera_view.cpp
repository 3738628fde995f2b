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

// The JSON document of GET /camera.json (docs/viewer.md): the frame of robot `robot` as `jpeg`,
// with the lines and the ball found in it (null when none).
std::string cameraDocument(int robot, const image_t& frame, bool from_preview,
                           const std::vector<std::uint8_t>& jpeg, const line_contours_t* lines,
                           const ball_observation_t* ball, std::int64_t encoded) {
  std::string out;
  out.reserve(jpeg.size() * 4 / 3 + 64 + (lines ? 24 * lines->num_points : 0));
  {
    json::Object doc(out);
    doc.integer("robot", robot);
    {
      json::Object f(doc.key("frame"));
      f.integer("utime", frame.header.utime);
      f.integer("seq", frame.header.seq);
      f.integer("frame_number", frame.frame_number);
      // The camera's size, which the line points are in; the JPEG is the preview's when the
      // frame came from CAMERA_PREVIEW (the page draws it at width x height).
      const int scale = from_preview ? bus::kCameraPreviewScale : 1;
      f.string("stream", from_preview ? "preview" : "full");
      f.integer("width", frame.width * scale);
      f.integer("height", frame.height * scale);
      f.integer("image_width", frame.width);
      f.integer("image_height", frame.height);
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
    doc.integer("encoded", encoded);
  }
  return out;
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
  previews_.clear();
  lines_.clear();
  balls_.clear();
  lines_seen_ = false;
  encoded_once_ = false;
  last_encoded_utime_ = 0;
}

namespace {

// Keeps `image` as the newest of at most `n` frames, reusing the oldest slot's buffers once the
// ring is full: no allocation per frame.
void keepFrame(std::deque<image_t>& ring, const image_t& image, std::size_t n) {
  if (ring.size() >= n) {
    image_t slot = std::move(ring.front());
    ring.pop_front();
    slot = image;
    ring.push_back(std::move(slot));
  } else {
    ring.push_back(image);
  }
}

}  // namespace

void CameraView::onImage(int robot, const image_t& image) {
  if (robot != selected_ || robot == 0) return;
  keepFrame(frames_, image, options_.frames_kept);
}

void CameraView::onPreview(int robot, const image_t& preview) {
  if (robot != selected_ || robot == 0) return;
  if (!frames_.empty() && frames_.back().header.utime >= preview.header.utime) return;
  keepFrame(previews_, preview, options_.frames_kept);
}

void CameraView::onLines(int robot, const line_contours_t& lines, Utime now) {
  if (robot != selected_ || robot == 0) return;
  lines_.push_back(lines);
  // Half a second at 30 Hz: long enough for a preview's lines to be found.
  keepAtMost(lines_, 16);
  last_lines_received_ = now;
  lines_seen_ = true;
}

void CameraView::onBall(int robot, const ball_observation_t& ball) {
  if (robot != selected_ || robot == 0) return;
  balls_.push_back(ball);
  keepAtMost(balls_, options_.frames_kept);
}

std::optional<std::string> CameraView::update(Utime now) {
  const bool from_preview = previewIsNewest();
  const std::deque<image_t>& frames = from_preview ? previews_ : frames_;
  if (selected_ == 0 || frames.empty() || tooSoon(now)) return std::nullopt;
  const Shown shown = frameToShow(frames, from_preview, now);
  if (!shown.frame) return std::nullopt;
  const ball_observation_t* ball = ballOf(*shown.frame);

  std::vector<std::uint8_t> jpeg;
  last_encode_ = now;
  encoded_once_ = true;
  last_encoded_utime_ = shown.frame->header.utime;
  try {
    jpeg = encodeJpeg(*shown.frame, options_.jpeg_quality);
  } catch (const std::exception& e) {
    ++frames_refused_;
    last_problem_ = e.what();
    return std::nullopt;
  }
  ++frames_encoded_;
  return cameraDocument(selected_, *shown.frame, from_preview, jpeg, shown.lines, ball,
                        frames_encoded_);
}

bool CameraView::previewIsNewest() const {
  // A viewer on another machine than the robot gets only previews.
  return !previews_.empty() &&
         (frames_.empty() || previews_.back().header.utime > frames_.back().header.utime);
}

bool CameraView::tooSoon(Utime now) const {
  const auto period = static_cast<Utime>(std::llround(kMicrosPerSecond / options_.max_rate_hz));
  return encoded_once_ && now - last_encode_ < period;
}

CameraView::Shown CameraView::frameToShow(const std::deque<image_t>& frames, bool from_preview,
                                          Utime now) const {
  // The newest frame the tracker's lines came for; else, with no lines for a while, the newest.
  Shown shown;
  for (auto l = lines_.rbegin(); l != lines_.rend() && !shown.frame; ++l) {
    if (l->header.utime <= last_encoded_utime_) break;
    for (const image_t& f : frames) {
      if (f.header.utime == l->header.utime) {
        shown = {&f, &*l};
        break;
      }
    }
  }
  // A preview whose lines went by (lines newer than it came, none of them its own) is shown
  // without them: previews are too rare to wait for another.
  const bool lines_went_by =
      from_preview && !lines_.empty() && lines_.back().header.utime > frames.back().header.utime;
  if (!shown.frame &&
      (!lines_seen_ || now - last_lines_received_ > options_.lines_missing_after_us ||
       lines_went_by) &&
      frames.back().header.utime > last_encoded_utime_) {
    shown.frame = &frames.back();
  }
  return shown;
}

const ball_observation_t* CameraView::ballOf(const image_t& frame) const {
  const ball_observation_t* ball = nullptr;
  for (const ball_observation_t& b : balls_) {
    if (b.header.utime == frame.header.utime) ball = &b;
  }
  return ball;
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
