// The viewer's side of a recording (fieldline-viewer --log, docs/viewer.md "Watching a
// recording"): every robot's ROBOT_STATE, BALL_STATE, TEAM_STATE, SERVICE_STATUS and the
// simulator's SIM_WORLD read into memory in log-time order (VISION_LINES by file offset, read when
// shown), each robot's clock from its RECORDING_INFO or fitted to its traffic; the team's picture
// at any log time (what a live viewer showed then: the last message of each kind received by
// that time) and the series the page plots over time.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <fieldline/ball_state_t.hpp>
#include <fieldline/line_contours_t.hpp>
#include <fieldline/robot_state_t.hpp>
#include <fieldline/service_status_t.hpp>
#include <fieldline/team_state_t.hpp>
#include <fieldline/world_state_t.hpp>

#include "common/bus/log_file.hpp"
#include "common/time/clock.hpp"
#include "tools/recording/clock_model.hpp"

namespace fieldline::viewer {

template <typename Msg>
struct Logged {
  // When the recorder received it (the log's time).
  Utime log_time = 0;
  Msg msg;
};

struct RobotRecording {
  int robot_id = 0;
  recording::RobotClockModel clock;
  std::vector<Logged<robot_state_t>> states;
  std::vector<Logged<ball_state_t>> balls;
  std::vector<Logged<team_state_t>> teams;
  // VISION_LINES: log time, the file and its offset (read when shown: they are most of a log).
  struct LinesAt {
    Utime log_time = 0;
    std::size_t file = 0;
    std::int64_t offset = 0;
    // header.utime_published - header.utime, ms (the tracker's latency, for the plot).
    double latency_ms = 0.0;
  };
  std::vector<LinesAt> lines;
  // By process name.
  std::map<std::string, std::vector<Logged<service_status_t>>> statuses;
};

class RecordingView {
 public:
  // `path`: a recording's directory (sim.lcm, robotN.lcm, robotN_partNNN.lcm) or one log. Throws
  // bus::LogError for an unreadable file, std::invalid_argument for a directory without logs.
  explicit RecordingView(const std::string& path);

  Utime start() const { return start_; }
  Utime end() const { return end_; }
  const std::vector<std::string>& files() const { return files_; }
  const std::vector<RobotRecording>& robots() const { return robots_; }
  bool hasTruth() const { return !worlds_.empty(); }
  // Events read, and refused by the readers' checks (by kind).
  std::int64_t eventsRead() const { return events_read_; }
  const std::map<std::string, std::int64_t>& refused() const { return refused_; }
  const std::map<std::string, std::int64_t>& upgraded() const { return upgraded_; }

  // The state document of TeamView (docs/viewer.md) as a live viewer would have shown it at log
  // time `t`: ages and staleness measured from `t`.
  std::string stateJson(Utime t);
  // The recording's description and the series over time, for the page's timeline and plots:
  // `start_utime`, `end_utime`, `files`, per robot its clock and, against seconds since the start
  // (the estimate's own time, converted with the robot's clock), `error` (m, against SIM_WORLD;
  // empty without truth), `heading_error` (deg), `sigma` (m, from the covariance), `status`
  // (its changes), `ball_error` (m), and per second `rate` (ROBOT_STATE Hz) and `latency`
  // (ROBOT_STATE and VISION_LINES, median ms).
  const std::string& seriesJson() const { return series_json_; }

 private:
  void read(const std::string& path, std::size_t file_index);
  RobotRecording& robot(int id);
  void makeSeries();

  std::vector<std::string> files_;
  std::vector<std::unique_ptr<bus::LogReader>> readers_;  // for VISION_LINES on demand
  std::vector<RobotRecording> robots_;
  std::vector<Logged<world_state_t>> worlds_;
  std::map<std::string, std::vector<Logged<service_status_t>>> sim_statuses_;
  Utime start_ = 0;
  Utime end_ = 0;
  std::int64_t events_read_ = 0;
  std::map<std::string, std::int64_t> refused_;
  std::map<std::string, std::int64_t> upgraded_;
  std::string series_json_;
};

}  // namespace fieldline::viewer
