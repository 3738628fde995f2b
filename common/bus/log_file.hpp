// LCM log files (lcm-logger's format), read with the same checks as live traffic and written
// for recording replays.
//
//   bus::LogReader log("run.lcmlog");
//   image_t image;
//   while (log.next(bus::channels::kCameraImage, image)) { ... }  // decoded and validated
//   for (const auto& [kind, count] : log.rejectedByKind()) { ... }
//
// A log is untrusted input like the network: damaged stretches of the file are skipped up to the
// next intact event (an event counts as intact when its lengths are sane and the next event's sync
// word or the end of the file follows it), and every event of a fieldline channel is decoded into
// its channel's type, validated (validate.hpp) and checked for a utime from the future (relative to
// the event's log time) before anyone sees it. What fails is counted by kind, with its event
// number.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "common/bus/channels.hpp"
#include "common/bus/checked_decode.hpp"
#include "common/time/clock.hpp"
#include "common/time/offset_clock.hpp"

namespace fieldline::bus {

// A log file that cannot be opened, read or written.
class LogError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One event of a log: a message as it was received.
struct LogEvent {
  // The logger's counter, 0, 1, 2, ... (gaps where it dropped events).
  std::int64_t number = 0;
  // When the logger received the message, µs since the epoch (the recording machine's clock).
  Utime timestamp = 0;
  std::string channel;
  std::vector<std::uint8_t> data;
  // Byte offset of the event in the file.
  std::int64_t offset = 0;
};

// Turns an event of an older version of its message type into today's (the project's upgrades:
// tools/recording/upgrade.hpp); returns the upgrade's name ("team_state_t v1"), or nothing when
// the event needs none. Installed once per process with setLogUpgrade().
using LogUpgrade = std::function<std::optional<std::string>(LogEvent& event)>;
// Every LogReader created afterwards upgrades old events as it reads them, before any check.
void setLogUpgrade(LogUpgrade upgrade);

// An event (or a damaged stretch of the file) that was not delivered.
struct LogRejection {
  // The event's number; -1 for damage that has none.
  std::int64_t event_number = -1;
  std::int64_t offset = 0;
  std::string channel;
  Rejection reason;
};

struct LogReaderOptions {
  // A message whose utime is beyond the event's log time plus this is rejected as from the
  // future (the same tolerance as bus::NodeOptions).
  Utime future_tolerance_us = 500'000;
  // The publishing robot's clock against the log's time (the recording machine's clock, see
  // tools/recording/clock_model.hpp): the future check compares a message's utime with the log
  // time as that robot's clock read it. Zero: the robot stamped with the recorder's clock.
  ClockError clock;
  // Events larger than this are taken as damage (a 4K BGR frame is 25 MB).
  std::int32_t max_event_bytes = 64 * 1024 * 1024;
};

class LogReader {
 public:
  // Throws LogError if `path` cannot be opened.
  explicit LogReader(const std::string& path, LogReaderOptions options = {});
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  // The next intact event of any channel, unchecked; false at the end of the file. Damaged
  // stretches on the way are counted ("damaged", "truncated") and skipped.
  bool nextEvent(LogEvent& event);

  // The next event of any channel that passes the checks for its channel's type; rejected events
  // (including channels not in channels.hpp) are counted and skipped. False at the end.
  bool nextChecked(LogEvent& event);

  // The next message on `channel`, decoded and checked; other channels are skipped without being
  // counted, rejected events of `channel` are counted. False at the end. `event`, if given, gets
  // the raw event (its number and log time).
  template <typename Msg>
  bool next(Channel<Msg> channel, Msg& msg, LogEvent* event = nullptr) {
    LogEvent& e = event ? *event : scratch_;
    while (nextEvent(e)) {
      if (e.channel != channel.name) continue;
      auto rejection = checkLogStamp(e);
      if (!rejection)
        rejection = decodeChecked(msg, e.data.data(), static_cast<int>(e.data.size()));
      if (!rejection) {
        rejection = checkNotFromFuture(msg.header, truthToOwn(options_.clock, e.timestamp),
                                       options_.future_tolerance_us);
      }
      if (!rejection) return true;
      reject(e, std::move(*rejection));
    }
    return false;
  }

  // Runs the checks of `event`'s channel type on it; counts and returns false if it fails.
  bool accept(const LogEvent& event);

  // Back to the first event (counts are kept).
  void rewind();
  // Continues at byte `offset` of the file (an event's LogEvent::offset).
  void seek(std::int64_t offset);
  // The clock the future check reads the log time on (LogReaderOptions::clock).
  void setClock(const ClockError& clock) { options_.clock = clock; }
  const ClockError& clock() const { return options_.clock; }

  const std::string& path() const { return path_; }
  // Rejected events and damaged stretches so far, by kind ("damaged", "truncated", "decode",
  // "wrong_type", "invalid", "future_utime", "unknown_channel").
  const std::map<std::string, std::int64_t>& rejectedByKind() const { return rejected_by_kind_; }
  std::int64_t rejectedTotal() const;
  // The most recent rejections, oldest first (at most 100 are kept).
  const std::deque<LogRejection>& recentRejections() const { return recent_; }
  // Intact events read so far.
  std::int64_t eventsRead() const { return events_read_; }
  // Events of older message versions upgraded while reading, by upgrade ("team_state_t v1").
  const std::map<std::string, std::int64_t>& upgradedByKind() const { return upgraded_; }

 private:
  // "bad_log_stamp" for an event whose log time is no time (negative, after 2100).
  static std::optional<Rejection> checkLogStamp(const LogEvent& event);
  void reject(const LogEvent& event, Rejection reason);
  void damage(std::int64_t offset, std::string kind, std::string text);

  struct Impl;
  std::string path_;
  LogReaderOptions options_;
  std::unique_ptr<Impl> impl_;
  LogEvent scratch_;
  std::map<std::string, std::int64_t> rejected_by_kind_;
  std::deque<LogRejection> recent_;
  std::int64_t events_read_ = 0;
  LogUpgrade upgrade_;
  std::map<std::string, std::int64_t> upgraded_;
};

// Writes an LCM log that lcm-logplayer, lcm-spy and LogReader read.
class LogWriter {
 public:
  // Creates (or truncates) `path`; throws LogError if it cannot.
  explicit LogWriter(const std::string& path);
  ~LogWriter();
  LogWriter(const LogWriter&) = delete;
  LogWriter& operator=(const LogWriter&) = delete;

  // Appends one event with log time `timestamp`; event numbers count from 0. Throws LogError if
  // the write fails.
  void write(std::string_view channel, Utime timestamp, const void* data, int size);
  // Encodes `msg` as it is (header included) and appends it.
  template <typename Msg>
  void write(Channel<Msg> channel, Utime timestamp, const Msg& msg) {
    buffer_.resize(static_cast<std::size_t>(msg.getEncodedSize()));
    if (msg.encode(buffer_.data(), 0, static_cast<int>(buffer_.size())) !=
        static_cast<int>(buffer_.size())) {
      throw LogError("cannot encode a " + std::string(Msg::getTypeName()));
    }
    write(channel.name, timestamp, buffer_.data(), static_cast<int>(buffer_.size()));
  }
  // Pushes what was written to the file.
  void flush();
  std::int64_t eventsWritten() const { return events_written_; }
  const std::string& path() const { return path_; }

 private:
  struct Impl;
  std::string path_;
  std::unique_ptr<Impl> impl_;
  std::vector<std::uint8_t> buffer_;
  std::int64_t events_written_ = 0;
};

}  // namespace fieldline::bus
