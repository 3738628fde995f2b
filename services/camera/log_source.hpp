// Replays the CAMERA_IMAGE frames of an LCM log file as a frame source (the frames are
// re-published with new stamps, like frames from a camera).
//
// The log is read through bus::LogReader, so every frame passes the checks a live CAMERA_IMAGE
// gets (decode, validate, no utime from the future); damaged stretches of the file and rejected
// frames are counted in errors() and skipped. Events of other channels are ignored.
#pragma once

#include <cstdint>
#include <memory>
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

 private:
  // Turns the reader's new rejections into counted errors.
  void countRejections();

  struct Impl;
  std::string path_;
  bool loop_;
  std::unique_ptr<Impl> impl_;
  std::int64_t rejections_counted_ = 0;
  std::int64_t delivered_ = 0;
};

}  // namespace fieldline::camera
