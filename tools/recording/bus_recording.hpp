// One bus into one recording's files: `DIR/NAME.lcm`, and when a size limit is set, further
// files `NAME_part002.lcm`, `NAME_part003.lcm`, ... (the oldest deleted beyond a count). Every
// file starts with a RECORDING_INFO (recording_info_t: the bus's robot, its clock, the settings,
// the field, the version) and repeats it every few seconds, so each file, cut or not, describes
// itself. Only messages that pass the checks a node applies are written; the rest are counted.
//
//   BusRecording robot3(dir, "robot3", info, {.max_file_bytes = 500 << 20}, clock_error);
//   robot3.write(channel, log_time, data, size);   // from the bus's raw subscription
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <fieldline/recording_info_t.hpp>

#include "common/bus/log_file.hpp"
#include "common/time/offset_clock.hpp"
#include "tools/recording/clock_model.hpp"

namespace fieldline::recording {

struct BusRecordingOptions {
  // Channels written; empty: every channel (CAMERA_IMAGE only with image_every > 0).
  std::vector<std::string> channels;
  // CAMERA_IMAGE: every image_every-th frame (counted per publisher) is written; 0: none.
  int image_every = 0;
  // A file reaching this size is closed and the next one started; 0: one file.
  std::int64_t max_file_bytes = 0;
  // At most this many files are kept, the oldest deleted first; 0: all.
  int max_files = 0;
  // RECORDING_INFO is repeated this often, s of log time.
  double info_period_s = 5.0;
};

class BusRecording {
 public:
  // `info`: the description written into every file (bus_robot_id, clock model, settings, field,
  // version); channels, image_every, file_index and max_file_bytes are filled here. Throws
  // bus::LogError when the first file cannot be created.
  BusRecording(std::string dir, std::string name, recording_info_t info,
               BusRecordingOptions options);

  // Writes one received message at log time `log_time` (the recording machine's clock) if its
  // channel is recorded and it passes the checks (decode, validate, not from the future of the
  // robot's clock); counts it otherwise. Throws bus::LogError when writing fails.
  void write(std::string_view channel, Utime log_time, const void* data, int size);
  // Writes the RECORDING_INFO now (also done at every file's start and every info_period_s).
  void writeInfo(Utime log_time);
  void flush();

  // The clock check: the envelope of utime_published - log time over the recent traffic.
  const std::optional<RobotClockModel>& observedClock() const { return observed_; }
  // The log time of the newest message the observed clock rests on: where it is to be compared
  // (a fit extrapolated beyond its data says nothing of the clock).
  Utime observedAt() const { return observed_at_; }

  const std::string& currentPath() const { return path_; }
  std::int64_t eventsWritten() const { return events_written_; }
  std::int64_t bytesWritten() const { return bytes_total_; }
  int filesStarted() const { return file_index_ + 1; }
  // Refused messages by kind ("invalid", "future_utime", "decode", ...), and images skipped by
  // the decimation.
  const std::map<std::string, std::int64_t>& refused() const { return refused_; }
  std::int64_t imagesSkipped() const { return images_skipped_; }
  std::string lastRefusal() const { return last_refusal_; }

 private:
  bool recorded(std::string_view channel) const;
  void startFile(Utime log_time);
  void observe(Utime log_time, const void* data, int size);
  // The size of the description in a file, event framing included.
  std::int64_t infoBytes() const;

  std::string dir_;
  std::string name_;
  recording_info_t info_;
  BusRecordingOptions options_;
  ClockError clock_;
  std::unique_ptr<bus::LogWriter> writer_;
  std::string path_;
  std::deque<std::string> files_;
  int file_index_ = -1;
  std::int64_t file_bytes_ = 0;
  std::int64_t bytes_total_ = 0;
  std::int64_t events_written_ = 0;
  Utime next_info_ = 0;
  std::map<std::string, std::int64_t> refused_;
  std::string last_refusal_;
  std::map<std::int64_t, std::int64_t> images_seen_;  // per publisher
  std::int64_t images_skipped_ = 0;
  std::vector<StampSample> recent_;
  std::optional<RobotClockModel> observed_;
  Utime observed_at_ = 0;
};

// The file name of part `index` (0: NAME.lcm, 1: NAME_part002.lcm, ...).
std::string partFileName(const std::string& name, int index);

}  // namespace fieldline::recording
