// fieldline-team-probe: one robot's side of the team tests. Publishes ROBOT_STATE (a fixed pose)
// and BALL_STATE (optionally a seen ball) at 50 Hz on the robot's bus, as fusion would, and writes
// every TEAM_STATE, with the system time it arrived, as a JSON line; at the end the teamcomm
// process's last SERVICE_STATUS error counts. Reads the robot's clock error from the same
// FIELDLINE_CLOCK_* variables as teamcomm. Stops by itself after --duration.
#include <fmt/format.h>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/cli/cli.hpp"
#include "common/msg/estimates.hpp"
#include "common/msg/team_state.hpp"
#include "common/time/offset_clock.hpp"

using namespace fieldline;

namespace {

std::string list(const auto& values) {
  std::string out = "[";
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i) out += ",";
    out += fmt::format("{}", values[i]);
  }
  return out + "]";
}

std::string object(const auto& map) {
  std::string out = "{";
  for (const auto& [k, v] : map)
    out += fmt::format("{}\"{}\":{}", out.size() > 1 ? "," : "", k, v);
  return out + "}";
}

struct Options {
  bus::CommonOptions common;
  std::string pose_text = "0,0,0", ball_text;
  std::string out_path;
  double duration_s = 10.0;

  void addTo(cli::App& app) {
    common.addTo(app);
    app.add_option("--pose", pose_text, "x,y,phi of the robot in the field frame")
        ->capture_default_str();
    app.add_option("--ball", ball_text, "x,y of a ball this robot sees (none when empty)");
    app.add_option("--out", out_path, "JSON lines file")->required();
    app.add_option("--duration", duration_s, "Seconds to run")
        ->check(cli::Range(0.5, 3600.0))
        ->capture_default_str();
  }
};

// One TEAM_STATE as a JSON line, with the system time it arrived.
std::string teamStateLine(const perception::TeamState& s, Utime arrived) {
  std::vector<int> present, ball_valid;
  std::vector<std::int64_t> age, ball_age, offset, rtt, received, rejected;
  std::vector<double> x, y;
  for (const auto& r : s.robots) {
    present.push_back(r.present);
    ball_valid.push_back(r.ball_valid);
    age.push_back(r.robot_age_us);
    ball_age.push_back(r.ball_age_us);
    offset.push_back(r.clock_offset_us);
    rtt.push_back(r.round_trip_us);
    received.push_back(r.packets_received);
    rejected.push_back(r.packets_rejected);
    x.push_back(r.x);
    y.push_back(r.y);
  }
  return fmt::format(
      "{{\"t\":{},\"utime\":{},\"present\":{},\"age\":{},\"ball_valid\":{},\"ball_age\":{},"
      "\"offset\":{},\"rtt\":{},\"received\":{},\"rejected\":{},\"x\":{},\"y\":{},"
      "\"team_ball\":[{},{},{}]}}\n",
      arrived, s.utime, list(present), list(age), list(ball_valid), list(ball_age), list(offset),
      list(rtt), list(received), list(rejected), list(x), list(y), s.team_ball_valid ? 1 : 0,
      s.team_ball_x, s.team_ball_y);
}

// What fusion would publish: the fixed pose, and the ball when one is given.
void publishEstimates(bus::Node& node, const std::vector<double>& pose,
                      const std::optional<std::vector<double>>& ball) {
  robot_state_t r{};
  perception::RobotEstimate e;
  e.utime = node.now() - 8'000;
  e.pose = {pose[0], pose[1], pose[2]};
  e.covariance = Eigen::Matrix3d::Identity() * 0.0025;
  e.status = perception::LocalizationStatus::kTracking;
  msg::toMessage(e, r);
  node.publish(bus::channels::kRobotState, r);
  ball_state_t b{};
  perception::BallEstimate be;
  be.utime = e.utime;
  be.valid = ball.has_value();
  if (ball) {
    be.x = (*ball)[0];
    be.y = (*ball)[1];
    be.last_seen_utime = e.utime - 30'000;
    be.covariance = Eigen::Matrix2d::Identity() * 0.01;
  }
  msg::toMessage(be, b);
  node.publish(bus::channels::kBallState, b);
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Team test probe: publishes a robot's ROBOT_STATE and BALL_STATE and records its "
      "TEAM_STATE as JSON lines."};
  Options o;
  o.addTo(app);
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  return bus::runMain("team_probe", [&] {
    o.common.resolve("team_probe");
    const auto pose = bus::parseNumberList(o.pose_text, 3, "--pose");
    std::optional<std::vector<double>> ball;
    if (!o.ball_text.empty()) ball = bus::parseNumberList(o.ball_text, 2, "--ball");
    SystemClock system_clock;
    const auto error = clockErrorFromEnvironment();
    OffsetClock clock(system_clock, error ? error->offset_us : 0, error ? error->drift_ppm : 0.0,
                      error ? error->reference_us : 0);
    bus::Node node({.process = "team_probe",
                    .robot_id = o.common.robot,
                    .url = o.common.bus_url,
                    .status_period_us = 0},
                   clock);
    std::ofstream out(o.out_path);
    node.subscribe(bus::channels::kTeamState, [&](const team_state_t& m) {
      // Flushed: tests wait for what the probe heard while it runs.
      out << teamStateLine(msg::fromMessage(m), system_clock.now()) << std::flush;
    });
    std::map<std::string, std::int64_t> errors;
    std::map<std::string, double> metrics;
    node.subscribe(bus::channels::kServiceStatus, [&](const service_status_t& m) {
      if (m.process != "teamcomm") return;
      for (int i = 0; i < m.num_errors; ++i)
        errors[m.error_kind[i]] = m.error_count[i];
      for (int i = 0; i < m.num_metrics; ++i)
        metrics[m.metric_name[i]] = m.metric_value[i];
      std::string reason;
      for (const char c : m.state_reason) {
        if (c == '"' || c == '\\') reason += '\\';
        if (static_cast<unsigned char>(c) >= 0x20) reason += c;
      }
      out << fmt::format("{{\"status_t\":{},\"state\":{},\"reason\":\"{}\",\"errors\":{}}}\n",
                         system_clock.now(), m.state, reason, object(errors))
          << std::flush;
    });
    node.every(20'000, [&] { publishEstimates(node, pose, ball); });
    // SIGTERM ends it as --duration does: with the final line.
    bus::installStopSignals();
    node.at(node.now() + static_cast<Utime>(o.duration_s * 1e6), [&] { node.requestStop(); });
    node.run();
    out << fmt::format("{{\"final\":1,\"errors\":{},\"metrics\":{}}}\n", object(errors),
                       object(metrics));
    return 0;
  });
}
