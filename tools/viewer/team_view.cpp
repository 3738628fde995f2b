#include "tools/viewer/team_view.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace fieldline::viewer {

namespace {

double ageSeconds(Utime now, Utime then) {
  return static_cast<double>(now - then) * 1e-6;
}

using json::Object;

void writeHeader(Object& o, const header_t& h, Utime now, Utime received) {
  o.integer("utime", h.utime);
  o.integer("utime_published", h.utime_published);
  o.integer("seq", h.seq);
  o.integer("robot_id", h.robot_id);
  o.number("age_s", ageSeconds(now, received));
}

void writeRobotState(std::string& out, const Received<robot_state_t>& r, Utime now) {
  const robot_state_t& m = r.msg;
  Object o(out);
  writeHeader(o, m.header, now, r.received);
  o.number("x", m.x);
  o.number("y", m.y);
  o.number("phi", m.phi);
  o.number("vx", m.vx);
  o.number("vy", m.vy);
  o.number("omega", m.omega);
  o.numbers("covariance", m.covariance, 9);
  o.integer("status", m.status);
  o.integer("since_vision_us", m.since_vision_us);
  o.boolean("twin_ambiguous", m.twin_ambiguous != 0);
}

void writeBallState(std::string& out, const Received<ball_state_t>& r, Utime now) {
  const ball_state_t& m = r.msg;
  Object o(out);
  writeHeader(o, m.header, now, r.received);
  o.boolean("valid", m.valid);
  o.number("x", m.x);
  o.number("y", m.y);
  o.number("vx", m.vx);
  o.number("vy", m.vy);
  o.numbers("covariance", m.covariance, 4);
  o.integer("last_seen_utime", m.last_seen_utime);
}

void writeTeamState(std::string& out, const Received<team_state_t>& r, Utime now) {
  const team_state_t& m = r.msg;
  const auto n = static_cast<std::size_t>(std::max(0, m.num_robots));
  Object o(out);
  writeHeader(o, m.header, now, r.received);
  o.integer("num_robots", m.num_robots);
  const auto booleans = [&](const char* name, const std::vector<std::int8_t>& values) {
    std::string& text = o.key(name);
    text += '[';
    for (std::size_t i = 0; i < n; ++i)
      text += (i > 0 ? "," : "") + std::string(values[i] ? "true" : "false");
    text += ']';
  };
  booleans("present", m.present);
  booleans("robot_twin_ambiguous", m.robot_twin_ambiguous);
  o.numbers("robot_x", m.robot_x.data(), n);
  o.numbers("robot_y", m.robot_y.data(), n);
  o.numbers("robot_phi", m.robot_phi.data(), n);
  o.numbers("robot_sigma_xy", m.robot_sigma_xy.data(), n);
  o.boolean("team_ball_valid", m.team_ball_valid);
  o.number("team_ball_x", m.team_ball_x);
  o.number("team_ball_y", m.team_ball_y);
  o.number("team_ball_vx", m.team_ball_vx);
  o.number("team_ball_vy", m.team_ball_vy);
  o.numbers("team_ball_covariance", m.team_ball_covariance, 4);
}

void writeVisionLines(std::string& out, const Received<line_contours_t>& r, Utime now) {
  const line_contours_t& m = r.msg;
  const auto n = static_cast<std::size_t>(std::max(0, m.num_points));
  Object o(out);
  writeHeader(o, m.header, now, r.received);
  o.integer("num_points", m.num_points);
  // Robot-frame floor positions: the page places them at the robot's estimated pose.
  o.numbers("x", m.x.data(), n);
  o.numbers("y", m.y.data(), n);
  o.integer("processing_us", m.processing_us);
}

void writeStatus(std::string& out, const Received<service_status_t>& r, Utime now,
                 Utime stale_after_us) {
  const service_status_t& m = r.msg;
  Object o(out);
  writeHeader(o, m.header, now, r.received);
  o.string("process", m.process);
  o.integer("pid", m.pid);
  o.number("uptime_s", static_cast<double>(m.uptime_us) * 1e-6);
  o.integer("state", m.state);
  o.boolean("stale", now - r.received > stale_after_us);
  {
    std::string& channels = o.key("channels");
    channels += '[';
    const auto n = static_cast<std::size_t>(std::max(0, m.num_channels));
    for (std::size_t i = 0; i < n; ++i) {
      if (i > 0) channels += ',';
      Object c(channels);
      c.string("name", m.channel[i]);
      c.string("direction", m.direction[i] == service_status_t::DIRECTION_OUT ? "out" : "in");
      c.integer("messages_total", m.messages_total[i]);
      c.number("rate_hz", m.rate_hz[i]);
      c.integer("drops_total", m.drops_total[i]);
      c.integer("rejected_total", m.rejected_total[i]);
      c.number("latency_p50_ms", m.latency_p50_ms[i]);
      c.number("latency_p95_ms", m.latency_p95_ms[i]);
      c.number("latency_max_ms", m.latency_max_ms[i]);
    }
    channels += ']';
  }
  o.number("processing_p50_ms", m.processing_p50_ms);
  o.number("processing_p95_ms", m.processing_p95_ms);
  {
    std::int64_t errors = 0;
    for (std::int64_t count : m.error_count)
      errors += count;
    o.integer("errors_total", errors);
  }
  o.string("last_error", m.last_error);
  {
    std::string& metrics = o.key("metrics");
    Object mo(metrics);
    const auto n = static_cast<std::size_t>(std::max(0, m.num_metrics));
    for (std::size_t i = 0; i < n; ++i)
      mo.number(m.metric_name[i], m.metric_value[i]);
  }
}

void writeSimWorld(std::string& out, const Received<world_state_t>& r, Utime now) {
  const world_state_t& m = r.msg;
  const auto n = static_cast<std::size_t>(std::max(0, m.num_robots));
  const auto k = static_cast<std::size_t>(std::max(0, m.num_opponents));
  Object o(out);
  writeHeader(o, m.header, now, r.received);
  o.string("field", m.field);
  o.string("scenario", m.scenario);
  o.numbers("robot_id", m.robot_id.data(), n);
  o.numbers("robot_x", m.robot_x.data(), n);
  o.numbers("robot_y", m.robot_y.data(), n);
  o.numbers("robot_phi", m.robot_phi.data(), n);
  o.number("robot_radius", m.robot_radius);
  o.numbers("opponent_x", m.opponent_x.data(), k);
  o.numbers("opponent_y", m.opponent_y.data(), k);
  o.numbers("opponent_radius", m.opponent_radius.data(), k);
  o.number("ball_x", m.ball_x);
  o.number("ball_y", m.ball_y);
  o.number("ball_radius", m.ball_radius);
}

template <typename Msg, typename Writer>
void optionalMember(Object& o, std::string_view name, const std::optional<Received<Msg>>& r,
                    Writer write, Utime now) {
  std::string& out = o.key(name);
  if (r)
    write(out, *r, now);
  else
    out += "null";
}

void writeStatuses(Object& o, const BusView& bus, Utime now, Utime stale_after_us) {
  std::string& out = o.key("processes");
  out += '[';
  bool first = true;
  for (const auto& [key, status] : bus.statuses) {
    if (!first) out += ',';
    first = false;
    writeStatus(out, status, now, stale_after_us);
  }
  out += ']';
}

void writePoint(std::string& out, const geometry::Vec2& p) {
  out += '[';
  json::appendNumber(out, p.x());
  out += ',';
  json::appendNumber(out, p.y());
  out += ']';
}

}  // namespace

TeamView::TeamView(const std::vector<int>& robot_ids) {
  for (int id : robot_ids) {
    if (id < 1 || id > 6) throw std::invalid_argument(fmt::format("robot {} not in 1..6", id));
    if (std::any_of(robots_.begin(), robots_.end(),
                    [id](const BusView& b) { return b.robot_id == id; }))
      throw std::invalid_argument(fmt::format("robot {} listed twice", id));
    robots_.push_back(BusView{.robot_id = id});
  }
}

BusView& TeamView::bus(int robot_id) {
  if (robot_id == 0) return sim_;
  for (BusView& b : robots_)
    if (b.robot_id == robot_id) return b;
  throw std::out_of_range(fmt::format("robot {} is not watched", robot_id));
}

std::string TeamView::toJson(Utime now, Utime stale_after_us) const {
  std::string out;
  out.reserve(16 * 1024);
  Object root(out);
  root.integer("utime", now);
  {
    std::string& robots = root.key("robots");
    robots += '[';
    for (std::size_t i = 0; i < robots_.size(); ++i) {
      const BusView& b = robots_[i];
      if (i > 0) robots += ',';
      Object r(robots);
      r.integer("id", b.robot_id);
      r.string("bus", b.url);
      optionalMember(r, "robot_state", b.robot_state, writeRobotState, now);
      optionalMember(r, "ball_state", b.ball_state, writeBallState, now);
      optionalMember(r, "team_state", b.team_state, writeTeamState, now);
      optionalMember(r, "vision_lines", b.vision_lines, writeVisionLines, now);
      writeStatuses(r, b, now, stale_after_us);
    }
    robots += ']';
  }
  {
    Object sim(root.key("sim"));
    sim.string("bus", sim_.url);
    optionalMember(sim, "world", sim_world_, writeSimWorld, now);
    writeStatuses(sim, sim_, now, stale_after_us);
  }
  return out;
}

std::string fieldJson(const field::FieldModel& model) {
  std::string out;
  Object o(out);
  o.string("name", model.name());
  o.number("length", model.length());
  o.number("width", model.width());
  {
    std::string& carpet = o.key("carpet_half_extent");
    writePoint(carpet, model.carpetHalfExtent());
  }
  {
    std::string& segments = o.key("segments");
    segments += '[';
    for (std::size_t i = 0; i < model.segments().size(); ++i) {
      const field::LineSegment& s = model.segments()[i];
      if (i > 0) segments += ',';
      Object so(segments);
      writePoint(so.key("a"), s.a);
      writePoint(so.key("b"), s.b);
      so.number("width", s.width);
    }
    segments += ']';
  }
  {
    std::string& arcs = o.key("arcs");
    arcs += '[';
    for (std::size_t i = 0; i < model.arcs().size(); ++i) {
      const field::LineArc& a = model.arcs()[i];
      if (i > 0) arcs += ',';
      Object ao(arcs);
      writePoint(ao.key("centre"), a.centre);
      ao.number("radius", a.radius);
      ao.number("start_angle", a.start_angle);
      ao.number("sweep", a.sweep);
      ao.number("width", a.width);
    }
    arcs += ']';
  }
  {
    std::string& goals = o.key("goals");
    goals += '[';
    for (std::size_t i = 0; i < model.goals().size(); ++i) {
      const field::Goal& g = model.goals()[i];
      if (i > 0) goals += ',';
      Object go(goals);
      writePoint(go.key("mouth_centre"), g.mouth_centre);
      writePoint(go.key("outward"), g.outward);
      go.number("width", g.width);
      go.number("depth", g.depth);
      go.string("colour", field::goalColourName(g.colour));
    }
    goals += ']';
  }
  {
    std::string& marks = o.key("penalty_marks");
    marks += '[';
    for (std::size_t i = 0; i < model.penaltyMarks().size(); ++i) {
      if (i > 0) marks += ',';
      writePoint(marks, model.penaltyMarks()[i]);
    }
    marks += ']';
  }
  o.number("penalty_mark_diameter", model.dimensions().penalty_mark_diameter);
  return out;
}

}  // namespace fieldline::viewer
