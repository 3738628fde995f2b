// Replays the CAMERA_IMAGE frames of an LCM log file as a frame source (the frames are
// re-published with new stamps, like frames from a camera).
//
// Reads the LCM log file format directly (each event: sync word 0xEDA1DA01, event number,
// timestamp, channel and data lengths, all big-endian, then channel name and data), so the
// camera needs no LCM runtime for it. Events of other channels are skipped; damaged events are
// counted and the reader resynchronises on the next sync word.
#pragma once

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include <fieldline/image_t.hpp>

#include "services/camera/sources.hpp"

namespace fieldline::camera {

class LogImageSource final : public FrameSource {
 public:
  // Throws std::runtime_error if the file cannot be opened.
  LogImageSource(const std::string& path, std::string channel, bool loop);
  bool next(SourceFrame& out) override;
  SourceKind kind() const override { return SourceKind::kLog; }
  std::string describe() const override;

 private:
  // Reads the next event of our channel into data_; false at the end of the file.
  bool readEvent();

  std::string path_;
  std::string channel_;
  bool loop_;
  std::ifstream in_;
  std::vector<std::uint8_t> data_;
  std::string event_channel_;
  image_t image_;
  std::int64_t delivered_ = 0;
};

// Appends one event to an LCM log (tests and tools that write logs without LCM).
void appendLogEvent(std::ostream& out, std::int64_t event_number, std::int64_t utime,
                    const std::string& channel, const std::vector<std::uint8_t>& data);

}  // namespace fieldline::camera
