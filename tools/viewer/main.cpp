// fieldline-viewer: the live field view. Listens to every robot's bus and the simulator's and
// serves a page (http://127.0.0.1:8080 by default) that draws the field, each robot's estimate
// with its covariance, its true pose where the simulator runs, the balls, the selected robot's
// line points and the status of every process. Read-only. See docs/viewer.md.
#include <algorithm>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/field/field_model.hpp"
#include "tools/viewer/team_view.hpp"
#include "tools/viewer/web_server.hpp"

#ifndef FIELDLINE_VIEWER_WEB_DIR
#error "FIELDLINE_VIEWER_WEB_DIR must name tools/viewer/web"
#endif

using namespace fieldline;

namespace {

// SERVICE_STATUS comes every second: three missed ones mean the process is gone or hung.
constexpr Utime kStatusStaleUs = 3 * kMicrosPerSecond;

template <typename Msg>
void keepLatest(bus::Node& node, bus::Channel<Msg> channel, bus::BusId bus,
                std::optional<viewer::Received<Msg>>& slot) {
  node.subscribe(
      channel,
      [&node, &slot](const Msg& m) {
        slot = viewer::Received<Msg>{m, node.now()};
      },
      bus);
}

void keepStatuses(bus::Node& node, bus::BusId bus, viewer::BusView& view) {
  node.subscribe(
      bus::channels::kServiceStatus,
      [&node, &view](const service_status_t& m) {
        view.statuses[{m.process, m.header.robot_id}] = {m, node.now()};
      },
      bus);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Live field view in the browser: listens to the robots' buses and the simulator's and "
      "serves the page, its state as JSON (GET /state.json) and a WebSocket (/ws) pushing it. "
      "Read-only: anything but GET gets 405."};
  viewer::WebServerOptions web;
  web.web_dir = FIELDLINE_VIEWER_WEB_DIR;
  std::string web_dir = web.web_dir.string();
  int port = web.port;
  std::vector<int> robots{1, 2, 3, 4, 5, 6};
  bool no_sim = false;
  std::string field_preset = "msl";
  double rate_hz = 20.0;
  bus::BusAddress address;
  bus::CommonOptions common;
  common.robot = 0;
  common.addTo(app);
  app.add_option("--address", web.address, "Address to serve on (0.0.0.0: every interface)")
      ->capture_default_str();
  app.add_option("--port", port, "TCP port to serve on (0: any free one, printed)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  app.add_option("--robots", robots, "Robots whose buses to watch")
      ->delimiter(',')
      ->check(CLI::Range(1, 6))
      ->capture_default_str();
  app.add_flag("--no-sim", no_sim, "Do not watch the simulator's bus (on a real team)");
  app.add_option("--field", field_preset, "Field preset name or YAML file to draw")
      ->capture_default_str();
  app.add_option("--rate", rate_hz, "WebSocket updates per second")
      ->check(CLI::Range(1.0, 100.0))
      ->capture_default_str();
  app.add_option("--web-dir", web_dir, "Directory with index.html and viewer.js")
      ->check(CLI::ExistingDirectory)
      ->capture_default_str();
  app.add_option("--base-port", address.base_port,
                 "Port of the simulator's bus; robot N's is this + N")
      ->check(CLI::Range(1, 65535 - 6))
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help is a ParseError too (exit code 0); every real one is a bad argument: 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  spdlog::set_level(spdlog::level::from_str(common.log_level));
  spdlog::set_pattern("%H:%M:%S.%e %^%l%$ viewer %v");
  web.port = static_cast<unsigned short>(port);
  web.web_dir = web_dir;
  web.push_period_s = 1.0 / rate_hz;
  std::sort(robots.begin(), robots.end());
  if (std::adjacent_find(robots.begin(), robots.end()) != robots.end()) {
    std::cerr << "--robots: a robot is listed twice\n";
    return 2;
  }

  return bus::runMain("viewer", [&] {
    const field::FieldModel field = field::loadFieldPreset(field_preset);
    viewer::TeamView team(robots);
    if (common.check_args) return 0;

    SystemClock clock;
    bus::installStopSignals();
    // The simulator's bus is the primary one (the viewer's own SERVICE_STATUS goes there); on a
    // real team the first robot's. fieldline-launch passes --bus-url and --sim-bus-url.
    const std::string sim_url =
        common.sim_bus_url.empty() ? bus::simBusUrl(address) : common.sim_bus_url;
    const std::string primary_url = !common.bus_url.empty() ? common.bus_url
                                    : no_sim ? bus::robotBusUrl(robots.front(), address)
                                             : sim_url;
    bus::Node node({.process = "viewer", .robot_id = 0, .url = primary_url}, clock);
    const auto busId = [&](const std::string& url) {
      return url == primary_url ? bus::kPrimaryBus : node.addBus(url);
    };
    if (!no_sim) {
      viewer::BusView& sim = team.bus(0);
      sim.url = sim_url;
      const bus::BusId id = busId(sim_url);
      node.subscribe(
          bus::channels::kSimWorld,
          [&](const world_state_t& m) { team.setSimWorld(m, node.now()); }, id);
      keepStatuses(node, id, sim);
    }
    for (int robot : robots) {
      viewer::BusView& view = team.bus(robot);
      view.url = bus::robotBusUrl(robot, address);
      const bus::BusId id = busId(view.url);
      keepLatest(node, bus::channels::kRobotState, id, view.robot_state);
      keepLatest(node, bus::channels::kBallState, id, view.ball_state);
      keepLatest(node, bus::channels::kTeamState, id, view.team_state);
      keepLatest(node, bus::channels::kVisionLines, id, view.vision_lines);
      keepStatuses(node, id, view);
    }

    viewer::WebServer server(web, viewer::fieldJson(field));
    node.every(static_cast<Utime>(1e6 / rate_hz), [&] {
      server.publish(team.toJson(node.now(), kStatusStaleUs));
      node.setMetric("web_socket_clients", server.webSocketClients());
      node.setMetric("methods_refused", static_cast<double>(server.methodsRefused()));
      node.setMetric("connections_refused", static_cast<double>(server.connectionsRefused()));
    });
    // Scripts (scripts/demo, the tests) read the address from this line.
    spdlog::info("serving http://{}:{}/ ({} robots{}, field {})", web.address, server.port(),
                 robots.size(), no_sim ? "" : " and the simulator", field.name());
    return node.run();
  });
}
