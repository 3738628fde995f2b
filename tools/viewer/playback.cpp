#include "tools/viewer/playback.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/bus/node.hpp"
#include "tools/json/json_text.hpp"
#include "tools/recording/upgrade.hpp"

namespace fieldline::viewer {

namespace {

std::optional<std::string> readFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

double parseNumber(const std::string& key, const std::string& text) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(v)) {
    throw std::invalid_argument(fmt::format("playback: {}={} is not a number", key, text));
  }
  return v;
}

}  // namespace

Playback::Playback(RecordingView& recording, PlaybackOptions options)
    : recording_(recording),
      options_(std::move(options)),
      playhead_(recording.start()),
      playing_(options_.play),
      speed_(options_.speed) {}

Utime Playback::playhead() const {
  std::lock_guard lock(mutex_);
  return playhead_;
}

double Playback::playheadSeconds() const {
  std::lock_guard lock(mutex_);
  return static_cast<double>(playhead_ - recording_.start()) * 1e-6;
}

bool Playback::playing() const {
  std::lock_guard lock(mutex_);
  return playing_;
}

double Playback::speed() const {
  std::lock_guard lock(mutex_);
  return speed_;
}

std::string Playback::statusJson() const {
  std::string out;
  json::Object o(out);
  o.number("t_s", static_cast<double>(playhead_ - recording_.start()) * 1e-6);
  o.number("duration_s", static_cast<double>(recording_.end() - recording_.start()) * 1e-6);
  o.integer("utime", playhead_);
  o.integer("start_utime", recording_.start());
  o.boolean("playing", playing_);
  o.number("speed", speed_);
  return out;
}

std::string Playback::tick(double elapsed_s) {
  Utime t = 0;
  std::string status;
  {
    std::lock_guard lock(mutex_);
    if (playing_) {
      playhead_ += static_cast<Utime>(std::llround(elapsed_s * speed_ * 1e6));
      if (playhead_ >= recording_.end()) {
        playhead_ = recording_.end();
        playing_ = false;
      }
    }
    t = playhead_;
    status = statusJson();
  }
  std::string doc = recording_.stateJson(t);
  // The team's picture with the playback's state as one more member.
  if (!doc.empty() && doc.back() == '}') {
    doc.pop_back();
    doc += ",\"playback\":" + status + "}";
  }
  return doc;
}

void Playback::control(const std::string& query) {
  std::lock_guard lock(mutex_);
  std::istringstream in(query);
  for (std::string item; std::getline(in, item, '&');) {
    if (item.empty()) continue;
    const auto eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const std::string value = eq == std::string::npos ? std::string{} : item.substr(eq + 1);
    if (key == "play") {
      if (playhead_ >= recording_.end()) playhead_ = recording_.start();
      playing_ = true;
    } else if (key == "pause") {
      playing_ = false;
    } else if (key == "speed") {
      const double s = parseNumber(key, value);
      if (!(s > 0.0 && s <= 100.0))
        throw std::invalid_argument("playback: speed must be in (0, 100]");
      speed_ = s;
    } else if (key == "t") {
      const double s = parseNumber(key, value);
      playhead_ = std::clamp(recording_.start() + static_cast<Utime>(std::llround(s * 1e6)),
                             recording_.start(), recording_.end());
    } else {
      throw std::invalid_argument("playback: unknown control '" + key +
                                  "' (play, pause, speed=S, t=S)");
    }
  }
}

std::optional<RouteReply> Playback::route(const std::string& path, const std::string& query) {
  if (path == "/recording.json") return RouteReply{recording_.seriesJson()};
  if (path == "/playback.json") {
    control(query);
    std::lock_guard lock(mutex_);
    return RouteReply{statusJson()};
  }
  if (path == "/playback.js") {
    if (auto text = readFile(options_.web_dir / "playback.js"))
      return RouteReply{std::move(*text), "text/javascript; charset=utf-8"};
    return std::nullopt;
  }
  if (path == "/lib/chart.min.js") {
    if (auto text = readFile(options_.chart_js))
      return RouteReply{std::move(*text), "text/javascript; charset=utf-8"};
    return std::nullopt;
  }
  return std::nullopt;
}

Route pageRoute(const std::filesystem::path& web_dir) {
  const PlaybackOptions defaults;
  return [web_dir, chart = defaults.chart_js](const std::string& path,
                                              const std::string&) -> std::optional<RouteReply> {
    const std::filesystem::path file = path == "/playback.js"        ? web_dir / "playback.js"
                                       : path == "/lib/chart.min.js" ? chart
                                                                     : std::filesystem::path{};
    if (file.empty()) return std::nullopt;
    auto text = readFile(file);
    if (!text) return std::nullopt;
    return RouteReply{std::move(*text), "text/javascript; charset=utf-8"};
  };
}

int runPlayback(const std::string& recording_path, const WebServerOptions& web,
                const std::string& field_json, PlaybackOptions options) {
  recording::installLogUpgrades();
  RecordingView recording(recording_path);
  std::string robots;
  for (const RobotRecording& r : recording.robots())
    robots += fmt::format(" {}", r.robot_id);
  std::string refused;
  for (const auto& [kind, n] : recording.refused())
    refused += fmt::format(" {} {}", kind, n);
  spdlog::info("recording {}: {} file(s), {:.1f} s, {} messages, robots{}{}; refused:{}",
               recording_path, recording.files().size(),
               static_cast<double>(recording.end() - recording.start()) * 1e-6,
               recording.eventsRead(), robots, recording.hasTruth() ? ", with truth" : "",
               refused.empty() ? " none" : refused);
  if (recording.robots().empty() && !recording.hasTruth()) {
    spdlog::error("recording {}: nothing to show (no ROBOT_STATE, no SIM_WORLD)", recording_path);
    return 1;
  }
  options.web_dir = web.web_dir;
  WebServer server(web, field_json);
  Playback playback(recording, options);
  server.setRoute([&playback](const std::string& path, const std::string& query) {
    return playback.route(path, query);
  });
  // Scripts (the tests) read the address from this line.
  spdlog::info("serving http://{}:{}/ (recording {})", web.address, server.port(), recording_path);
  auto last = std::chrono::steady_clock::now();
  while (!bus::stopSignalReceived()) {
    std::this_thread::sleep_for(std::chrono::duration<double>(web.push_period_s));
    const auto now = std::chrono::steady_clock::now();
    server.publish(playback.tick(std::chrono::duration<double>(now - last).count()));
    last = now;
  }
  return 0;
}

}  // namespace fieldline::viewer
