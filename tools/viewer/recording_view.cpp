#include "tools/viewer/recording_view.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "common/bus/channels.hpp"
#include "tools/json/json_text.hpp"
#include "tools/recording/recording_info.hpp"
#include "tools/viewer/team_view.hpp"

namespace fieldline::viewer {

namespace ch = bus::channels;

namespace {

// Points per series sent to the page at most (every n-th sample beyond).
constexpr std::size_t kMaxPoints = 3000;

// The last element logged at or before `t`, or nullptr.
template <typename T>
const T* lastAt(const std::vector<T>& items, Utime t) {
  const auto it = std::upper_bound(items.begin(), items.end(), t,
                                   [](Utime v, const T& item) { return v < item.log_time; });
  return it == items.begin() ? nullptr : &*std::prev(it);
}

template <typename Msg>
bool decode(Msg& msg, const bus::LogEvent& e) {
  return msg.decode(e.data.data(), 0, static_cast<int>(e.data.size())) ==
         static_cast<int>(e.data.size());
}

template <typename T>
void sortByLogTime(std::vector<T>& items) {
  std::stable_sort(items.begin(), items.end(),
                   [](const T& a, const T& b) { return a.log_time < b.log_time; });
}

// Appends [[x, y], ...] with at most kMaxPoints pairs.
void appendPoints(std::string& out, const std::vector<std::pair<double, double>>& points) {
  const std::size_t step = std::max<std::size_t>(1, (points.size() + kMaxPoints - 1) / kMaxPoints);
  out += '[';
  bool first = true;
  for (std::size_t i = 0; i < points.size(); i += step) {
    if (!first) out += ',';
    first = false;
    out += '[';
    json::appendNumber(out, std::round(points[i].first * 1000.0) / 1000.0);
    out += ',';
    json::appendNumber(out, points[i].second);
    out += ']';
  }
  out += ']';
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Appends ["a", ...].
void appendStrings(std::string& out, const std::vector<std::string>& texts) {
  out += '[';
  for (std::size_t i = 0; i < texts.size(); ++i) {
    if (i > 0) out += ',';
    json::appendString(out, texts[i]);
  }
  out += ']';
}

// Appends {"kind": n, ...}.
void appendCounts(std::string& out, const std::map<std::string, std::int64_t>& counts) {
  json::Object o(out);
  for (const auto& [kind, n] : counts)
    o.integer(kind, n);
}

// The recording's span; series are plotted against seconds since its start.
struct Timeline {
  Utime start = 0;
  Utime end = 0;
  double seconds(Utime t) const {
    return (static_cast<double>(t) - static_cast<double>(start)) * 1e-6;
  }
};

using Series = std::vector<std::pair<double, double>>;
using Worlds = std::vector<Logged<world_state_t>>;

// The simulator's truth at one time: a robot's pose and the ball.
struct Truth {
  double x = 0.0, y = 0.0, phi = 0.0;
  double ball_x = 0.0, ball_y = 0.0;
};

// The truth at time `truth` (the simulator's clock, the log's), interpolated between the two
// SIM_WORLD around it; nullopt outside them, across a gap of more than 50 ms, or when `robot` is
// not in both (robot 0: the ball only).
std::optional<Truth> truthAt(const Worlds& worlds, Utime truth, int robot) {
  const auto it = std::lower_bound(
      worlds.begin(), worlds.end(), truth,
      [](const Logged<world_state_t>& w, Utime v) { return w.msg.header.utime < v; });
  if (it == worlds.end() || it == worlds.begin()) return std::nullopt;
  const world_state_t& b = it->msg;
  const world_state_t& a = std::prev(it)->msg;
  if (b.header.utime - a.header.utime > 50'000) return std::nullopt;
  const double w = b.header.utime == a.header.utime
                       ? 0.0
                       : static_cast<double>(truth - a.header.utime) /
                             static_cast<double>(b.header.utime - a.header.utime);
  Truth t;
  t.ball_x = a.ball_x + (b.ball_x - a.ball_x) * w;
  t.ball_y = a.ball_y + (b.ball_y - a.ball_y) * w;
  if (robot == 0) return t;
  const auto find = [robot](const world_state_t& s) -> int {
    for (int i = 0; i < s.num_robots; ++i)
      if (s.robot_id[static_cast<std::size_t>(i)] == robot) return i;
    return -1;
  };
  const int ia = find(a);
  const int ib = find(b);
  if (ia < 0 || ib < 0) return std::nullopt;
  const auto ka = static_cast<std::size_t>(ia);
  const auto kb = static_cast<std::size_t>(ib);
  t.x = a.robot_x[ka] + (b.robot_x[kb] - a.robot_x[ka]) * w;
  t.y = a.robot_y[ka] + (b.robot_y[kb] - a.robot_y[ka]) * w;
  t.phi =
      a.robot_phi[ka] + std::remainder(b.robot_phi[kb] - a.robot_phi[ka], 2 * std::numbers::pi) * w;
  return t;
}

// What the page plots of one robot, each against seconds since the start.
struct RobotSeries {
  Series error, heading, sigma, status, ball_error, rate, latency, lines_latency;
};

// From its ROBOT_STATE, on the estimate's own time: sigma, the status (its changes, and the last
// one at the end) and, with truth, the position and heading errors.
void addStateSeries(RobotSeries& series, const RobotRecording& r, const Worlds& worlds,
                    const Timeline& timeline) {
  int last_status = -1;
  for (const Logged<robot_state_t>& s : r.states) {
    const robot_state_t& m = s.msg;
    const Utime truth = r.clock.logAt(m.header.utime);
    const double t = timeline.seconds(truth);
    series.sigma.emplace_back(t, std::sqrt(std::max(0.0, m.covariance[0] + m.covariance[4])));
    if (m.status != last_status) {
      series.status.emplace_back(t, m.status);
      last_status = m.status;
    }
    if (const auto at = truthAt(worlds, truth, r.robot_id)) {
      series.error.emplace_back(t, std::hypot(m.x - at->x, m.y - at->y));
      series.heading.emplace_back(
          t, std::abs(std::remainder(m.phi - at->phi, 2 * std::numbers::pi)) * 180.0 /
                 std::numbers::pi);
    }
  }
  if (!r.states.empty())
    series.status.emplace_back(timeline.seconds(timeline.end), r.states.back().msg.status);
}

// From its valid BALL_STATE, with truth: the ball's position error.
void addBallErrors(RobotSeries& series, const RobotRecording& r, const Worlds& worlds,
                   const Timeline& timeline) {
  for (const Logged<ball_state_t>& b : r.balls) {
    if (!b.msg.valid) continue;
    const Utime truth = r.clock.logAt(b.msg.header.utime);
    if (const auto at = truthAt(worlds, truth, 0))
      series.ball_error.emplace_back(timeline.seconds(truth),
                                     std::hypot(b.msg.x - at->ball_x, b.msg.y - at->ball_y));
  }
}

// Per second of log time: the median of `latencyOf` over the `items` logged in it into
// `latency` and, with `rate`, how many there were.
template <typename Items, typename LatencyOf>
void addPerSecond(const Items& items, LatencyOf latencyOf, const Timeline& timeline, Series* rate,
                  Series& latency) {
  std::size_t i = 0;
  for (Utime s0 = timeline.start; s0 <= timeline.end && i < items.size(); s0 += kMicrosPerSecond) {
    std::vector<double> l;
    while (i < items.size() && items[i].log_time < s0 + kMicrosPerSecond)
      l.push_back(latencyOf(items[i++]));
    const double t = timeline.seconds(s0) + 0.5;
    if (rate) rate->emplace_back(t, static_cast<double>(l.size()));
    if (!l.empty()) latency.emplace_back(t, median(std::move(l)));
  }
}

// Appends the robot's member of the series document (RecordingView::seriesJson()).
void appendRobotSeries(std::string& out, const RobotRecording& r, const Worlds& worlds,
                       const Timeline& timeline) {
  json::Object o(out);
  o.integer("id", r.robot_id);
  o.string("clock", r.clock.describe());
  RobotSeries series;
  addStateSeries(series, r, worlds, timeline);
  addBallErrors(series, r, worlds, timeline);
  addPerSecond(
      r.states,
      [](const Logged<robot_state_t>& s) {
        return static_cast<double>(s.msg.header.utime_published - s.msg.header.utime) * 1e-3;
      },
      timeline, &series.rate, series.latency);
  addPerSecond(
      r.lines, [](const RobotRecording::LinesAt& l) { return l.latency_ms; }, timeline, nullptr,
      series.lines_latency);
  appendPoints(o.key("error"), series.error);
  appendPoints(o.key("heading_error"), series.heading);
  appendPoints(o.key("sigma"), series.sigma);
  appendPoints(o.key("status"), series.status);
  appendPoints(o.key("ball_error"), series.ball_error);
  appendPoints(o.key("rate"), series.rate);
  appendPoints(o.key("latency"), series.latency);
  appendPoints(o.key("lines_latency"), series.lines_latency);
}

}  // namespace

RecordingView::RecordingView(const std::string& path) : files_(recording::recordingFiles(path)) {
  for (std::size_t i = 0; i < files_.size(); ++i)
    read(files_[i], i);
  for (RobotRecording& r : robots_) {
    sortByLogTime(r.states);
    sortByLogTime(r.balls);
    sortByLogTime(r.teams);
    sortByLogTime(r.lines);
    for (auto& [name, s] : r.statuses)
      sortByLogTime(s);
  }
  sortByLogTime(worlds_);
  for (auto& [name, s] : sim_statuses_)
    sortByLogTime(s);
  std::sort(robots_.begin(), robots_.end(), [](const RobotRecording& a, const RobotRecording& b) {
    return a.robot_id < b.robot_id;
  });
  makeSeries();
}

RobotRecording& RecordingView::robot(int id) {
  for (RobotRecording& r : robots_)
    if (r.robot_id == id) return r;
  robots_.push_back(RobotRecording{.robot_id = id});
  return robots_.back();
}

void RecordingView::read(const std::string& path, std::size_t file_index) {
  // Whose bus and on which clock: the file's RECORDING_INFO, else fitted to its traffic.
  std::map<int, recording::RobotClockModel> clocks = recording::estimateClocks(path);
  if (const auto info = recording::readRecordingInfo(path))
    clocks[info->bus_robot_id] = recording::clockOf(*info);
  for (const auto& [id, model] : clocks) {
    if (id >= 1 && id <= 6) robot(id).clock = model;
  }
  // Stamps are checked against the log time on the clock of the file's robot.
  ClockError file_clock;
  for (const auto& [id, model] : clocks)
    if (id != 0) file_clock = model.error;
  auto reader = std::make_unique<bus::LogReader>(path, bus::LogReaderOptions{.clock = file_clock});
  bus::LogEvent e;
  while (reader->nextEvent(e)) {
    if (e.channel == ch::kCameraImage.name || e.channel == ch::kRecordingInfo.name) continue;
    if (!reader->accept(e)) continue;
    ++events_read_;
    if (start_ == 0 || e.timestamp < start_) start_ = e.timestamp;
    end_ = std::max(end_, e.timestamp);
    if (e.channel == ch::kSimWorld.name) {
      Logged<world_state_t> w{e.timestamp, {}};
      if (decode(w.msg, e)) worlds_.push_back(std::move(w));
    } else if (e.channel == ch::kRobotState.name) {
      Logged<robot_state_t> s{e.timestamp, {}};
      if (decode(s.msg, e)) robot(s.msg.header.robot_id).states.push_back(std::move(s));
    } else if (e.channel == ch::kBallState.name) {
      Logged<ball_state_t> b{e.timestamp, {}};
      if (decode(b.msg, e)) robot(b.msg.header.robot_id).balls.push_back(std::move(b));
    } else if (e.channel == ch::kTeamState.name) {
      Logged<team_state_t> t{e.timestamp, {}};
      if (decode(t.msg, e)) robot(t.msg.header.robot_id).teams.push_back(std::move(t));
    } else if (e.channel == ch::kVisionLines.name) {
      if (const auto h = recording::peekHeader(e.data.data(), static_cast<int>(e.data.size()))) {
        robot(h->robot_id)
            .lines.push_back({e.timestamp, file_index, e.offset,
                              static_cast<double>(h->utime_published - h->utime) * 1e-3});
      }
    } else if (e.channel == ch::kServiceStatus.name) {
      Logged<service_status_t> s{e.timestamp, {}};
      if (!decode(s.msg, e)) continue;
      const int id = s.msg.header.robot_id;
      if (id >= 1 && id <= 6)
        robot(id).statuses[s.msg.process].push_back(std::move(s));
      else
        sim_statuses_[s.msg.process].push_back(std::move(s));
    }
  }
  for (const auto& [kind, n] : reader->rejectedByKind())
    refused_[kind] += n;
  for (const auto& [kind, n] : reader->upgradedByKind())
    upgraded_[kind] += n;
  if (readers_.size() <= file_index) readers_.resize(file_index + 1);
  readers_[file_index] = std::move(reader);
}

std::string RecordingView::stateJson(Utime t) {
  std::vector<int> ids;
  for (const RobotRecording& r : robots_)
    ids.push_back(r.robot_id);
  TeamView team(ids);
  for (const RobotRecording& r : robots_) {
    BusView& view = team.bus(r.robot_id);
    view.url = "recording";
    if (const auto* s = lastAt(r.states, t))
      view.robot_state = Received<robot_state_t>{s->msg, s->log_time};
    if (const auto* b = lastAt(r.balls, t))
      view.ball_state = Received<ball_state_t>{b->msg, b->log_time};
    if (const auto* m = lastAt(r.teams, t))
      view.team_state = Received<team_state_t>{m->msg, m->log_time};
    if (const auto* l = lastAt(r.lines, t); l && l->file < readers_.size() && readers_[l->file]) {
      bus::LogReader& reader = *readers_[l->file];
      reader.seek(l->offset);
      bus::LogEvent e;
      line_contours_t lines;
      if (reader.nextEvent(e) && decode(lines, e))
        view.vision_lines = Received<line_contours_t>{std::move(lines), l->log_time};
    }
    for (const auto& [process, statuses] : r.statuses) {
      if (const auto* s = lastAt(statuses, t))
        view.statuses[{process, r.robot_id}] = Received<service_status_t>{s->msg, s->log_time};
    }
  }
  BusView& sim = team.bus(0);
  sim.url = "recording";
  for (const auto& [process, statuses] : sim_statuses_) {
    if (const auto* s = lastAt(statuses, t))
      sim.statuses[{process, 0}] = Received<service_status_t>{s->msg, s->log_time};
  }
  if (const auto* w = lastAt(worlds_, t)) team.setSimWorld(w->msg, w->log_time);
  return team.toJson(t, kStatusStaleUs);
}

void RecordingView::makeSeries() {
  const Timeline timeline{start_, end_};
  std::string out;
  {
    json::Object root(out);
    root.integer("start_utime", start_);
    root.integer("end_utime", end_);
    root.boolean("truth", hasTruth());
    root.integer("events", events_read_);
    appendStrings(root.key("files"), files_);
    std::string& robots = root.key("robots");
    robots += '[';
    for (std::size_t k = 0; k < robots_.size(); ++k) {
      if (k > 0) robots += ',';
      appendRobotSeries(robots, robots_[k], worlds_, timeline);
    }
    robots += ']';
    appendCounts(root.key("refused"), refused_);
    appendCounts(root.key("upgraded"), upgraded_);
  }  // the document is closed here
  series_json_ = std::move(out);
}

}  // namespace fieldline::viewer
