// The viewer's camera view: the selected robot's CAMERA_IMAGE, a few times a second, as a JPEG
// together with what the region tracker found in that very frame: the VISION_LINES points (image
// coordinates u, v, in their sequences along the green regions' contours) and the VISION_BALL
// observation, matched to the frame by its exposure time (header.utime).
//
// The tracked region boundaries themselves are not on the bus (only the line points found along
// them are); the view shows what the tracker published, nothing recomputed.
//
// A viewer on another machine than the robot gets no CAMERA_IMAGE (the full frames never leave
// the robot) but CAMERA_PREVIEW, the same frames at 1/kCameraPreviewScale of their size a few
// times a second: shown in their place, drawn at the camera's size so the line points fit. Full
// frames win while they come.
//
// Frames of the selected robot only are kept (a few, to wait for their VISION_LINES); nothing is
// encoded faster than max_rate_hz. Plain library: no bus, no clock of its own.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include <fieldline/ball_observation_t.hpp>
#include <fieldline/image_t.hpp>
#include <fieldline/line_contours_t.hpp>

#include "common/bus/channels.hpp"
#include "common/time/clock.hpp"

namespace fieldline::viewer {

struct CameraViewOptions {
  // JPEGs per second at most.
  double max_rate_hz = 5.0;
  int jpeg_quality = 80;
  // Frames kept while waiting for their VISION_LINES (30 Hz camera: 8 frames = 0.27 s).
  std::size_t frames_kept = 8;
  // Without any VISION_LINES for this long, frames are shown without lines (tracker down).
  Utime lines_missing_after_us = kMicrosPerSecond;
};

class CameraView {
 public:
  explicit CameraView(CameraViewOptions options = {});

  // The robot whose camera is shown (0: none). Another robot than before forgets what was kept.
  void select(int robot);
  int selected() const { return selected_; }

  // Messages of robot `robot`'s bus (ignored unless it is the selected one); `now`: viewer clock.
  void onImage(int robot, const image_t& image);
  // CAMERA_PREVIEW of robot `robot` (ignored while full frames of it are newer).
  void onPreview(int robot, const image_t& preview);
  void onLines(int robot, const line_contours_t& lines, Utime now);
  void onBall(int robot, const ball_observation_t& ball);

  // At most max_rate_hz: the newest kept frame that its VISION_LINES came for (or, when the
  // tracker has published nothing for a while, the newest frame) as the JSON document of
  // GET /camera.json (docs/viewer.md), with the JPEG in base64. nullopt when there is nothing
  // new, it is too soon, or the frame cannot be encoded (counted in framesRefused()).
  std::optional<std::string> update(Utime now);

  std::int64_t framesEncoded() const { return frames_encoded_; }
  std::int64_t framesRefused() const { return frames_refused_; }
  const std::string& lastProblem() const { return last_problem_; }

 private:
  // A frame to show and the VISION_LINES found in it (nullptr: shown without lines).
  struct Shown {
    const image_t* frame = nullptr;
    const line_contours_t* lines = nullptr;
  };
  // True when the newest frame is a preview (a viewer on another machine gets only those).
  bool previewIsNewest() const;
  // True while the last JPEG is younger than 1 / max_rate_hz.
  bool tooSoon(Utime now) const;
  // Which of `frames` update() shows (frame nullptr: none yet, it waits for their lines).
  Shown frameToShow(const std::deque<image_t>& frames, bool from_preview, Utime now) const;
  // The VISION_BALL of `frame` (matched by exposure time), or nullptr.
  const ball_observation_t* ballOf(const image_t& frame) const;

  CameraViewOptions options_;
  int selected_ = 0;
  std::deque<image_t> frames_;    // oldest first
  std::deque<image_t> previews_;  // oldest first
  std::deque<line_contours_t> lines_;
  std::deque<ball_observation_t> balls_;
  Utime last_lines_received_ = 0;
  bool lines_seen_ = false;
  Utime last_encode_ = 0;
  bool encoded_once_ = false;
  std::int64_t last_encoded_utime_ = 0;
  std::int64_t frames_encoded_ = 0;
  std::int64_t frames_refused_ = 0;
  std::string last_problem_;
};

// The frame as JPEG (YUYV, BGR or grey); throws std::invalid_argument for a frame whose sizes do
// not fit its data or an unknown format.
std::vector<std::uint8_t> encodeJpeg(const image_t& image, int quality);
// Standard base64 (RFC 4648, with padding).
std::string base64(const std::vector<std::uint8_t>& bytes);

}  // namespace fieldline::viewer
