// fieldline-viewer --log: plays a recording into the page as the live viewer shows the team
// (docs/viewer.md, "Watching a recording"). A playhead in the recording's log time moves with the
// wall clock times the speed while playing; at every tick the team's picture at the playhead
// (RecordingView::stateJson, ages counted from the playhead: replayed time is not stale) goes to
// the page over the same WebSocket as live states, with a "playback" member (t_s, duration_s,
// playing, speed). The page's timeline controls it with GET /playback.json?play|pause|speed=S|t=S
// and plots /recording.json (the series) with Chart.js, served from the Debian package
// (libjs-chart.js) at /lib/chart.min.js.
#pragma once

#include <filesystem>
#include <mutex>
#include <optional>
#include <string>

#include "tools/viewer/recording_view.hpp"
#include "tools/viewer/web_server.hpp"

namespace fieldline::viewer {

struct PlaybackOptions {
  // Where the page's playback.js is (the viewer's web directory).
  std::filesystem::path web_dir;
  // Chart.js from Debian's libjs-chart.js.
  std::filesystem::path chart_js = "/usr/share/javascript/chart.js/chart.min.js";
  // Start playing at once, at this speed.
  bool play = false;
  double speed = 1.0;
};

class Playback {
 public:
  Playback(RecordingView& recording, PlaybackOptions options);

  // Moves the playhead by `elapsed_s` of wall time (times the speed, while playing; it stops at
  // the end) and returns the state document at the playhead. Not thread-safe against itself:
  // one thread ticks.
  std::string tick(double elapsed_s);
  // The routes of the web server: /recording.json, /playback.json?..., /playback.js,
  // /lib/chart.min.js. Throws std::invalid_argument for a bad control query. Any thread.
  std::optional<RouteReply> route(const std::string& path, const std::string& query);

  // The playhead, µs of log time; seconds since the recording's start.
  Utime playhead() const;
  double playheadSeconds() const;
  bool playing() const;
  double speed() const;

 private:
  std::string statusJson() const;  // under mutex_
  void control(const std::string& query);

  RecordingView& recording_;
  PlaybackOptions options_;
  mutable std::mutex mutex_;
  Utime playhead_ = 0;
  bool playing_ = false;
  double speed_ = 1.0;
};

// Serves a recording (fieldline-viewer --log) until SIGINT/SIGTERM: the page, its field, and
// the team's picture at the playhead pushed `push_period_s` apart. Returns the exit code.
int runPlayback(const std::string& recording_path, const WebServerOptions& web,
                const std::string& field_json, PlaybackOptions options);

// The page's own scripts for a live viewer (/playback.js, which finds no recording there and
// leaves the page as it is, and /lib/chart.min.js).
Route pageRoute(const std::filesystem::path& web_dir);

}  // namespace fieldline::viewer
