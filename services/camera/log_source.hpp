// Replays the CAMERA_IMAGE frames of an LCM log file as a frame source. Each frame carries its
// logged exposure time (SourceFrame::recorded_utime), which the camera keeps by default
// (--keep-stamps; --restamp stamps them like frames from a camera). When looping, every pass
// is shifted by the log's length so the stamps keep increasing.
//
// The log is read through bus::LogReader, so every frame passes the checks a live CAMERA_IMAGE
// gets (decode, validate, no utime from the future); damaged stretches of the file and rejected
// frames are counted in errors() and skipped. Events of other channels are ignored.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "services/camera/sources.hpp"

namespace fieldline::camera {

class LogImageSource final : public FrameSource {
 public:
  // Throws std::runtime_error (bus::LogError) if the file cannot be opened.
  LogImageSource(const std::string& path, bool loop);
  ~LogImageSource() override;
  bool next(SourceFrame& out) override;
  SourceKind kind() const override { return SourceKind::kLog; }
  std::string describe() const override;

  // The exposure time of the first valid CAMERA_IMAGE of the log at `path`, or nothing when it
  // has none. Throws like the constructor.
  static std::optional<std::int64_t> firstUtime(const std::string& path);

 private:
  // Turns the reader's new rejections into counted errors.
  void countRejections();

  struct Impl;
  std::string path_;
  bool loop_;
  std::unique_ptr<Impl> impl_;
  std::int64_t rejections_counted_ = 0;
  std::int64_t delivered_ = 0;
  // Added to the logged stamps: grows by the log's length (plus one frame period) per rewind.
  std::int64_t loop_shift_ = 0;
  std::optional<std::int64_t> first_utime_;
  std::int64_t last_utime_ = 0;
  std::int64_t delivered_in_pass_ = 0;
};

}  // namespace fieldline::camera
